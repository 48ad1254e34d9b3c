; Mobile manipulation in a kitchen: a base that drives between tables and counters and an
; arm that picks and places objects; objects are cleaned at the sink and cooked on the stove.
(define (domain mobile-kitchen)
  (:requirements :strips :equality)     ; lax: derived predicates and costs are used below
  (:predicates
    (Arm ?a) (Object ?o) (Region ?r)    ; "types"
    (Sink ?r) (Stove ?r)
    (Stackable ?o ?r)
    (Pose ?o ?p) (Grasp ?o ?g)
    (BConf ?q) (BTraj ?t) (ATraj ?t)
    (Supported ?o ?p ?r)
    (Kin ?a ?o ?p ?g ?q ?t)
    (BaseMotion ?q1 ?t ?q2)
    (CFreePosePose ?o ?p ?o2 ?p2)
    (AtPose ?o ?p) (AtGrasp ?a ?o ?g) (HandEmpty ?a)
    (AtBConf ?q) (CanMove)
    (Cleaned ?o) (Cooked ?o))
  (:functions (Distance ?q1 ?q2))

  (:action move_base
    :parameters (?q1 ?q2 ?t)
    :precondition (and (BaseMotion ?q1 ?t ?q2)
                       (AtBConf ?q1) (CanMove))
    :effect (and (AtBConf ?q2)
                 (not (AtBConf ?q1)) (not (CanMove))
                 (increase (total-cost) (Distance ?q1 ?q2))))

  (:action pick
    :parameters (?a ?o ?p ?g ?q ?t)
    :precondition (and (Kin ?a ?o ?p ?g ?q ?t)
                       (AtPose ?o ?p) (HandEmpty ?a) (AtBConf ?q))
    :effect (and (AtGrasp ?a ?o ?g) (CanMove)
                 (not (AtPose ?o ?p)) (not (HandEmpty ?a))
                 (increase (total-cost) 1)))

  (:action place
    :parameters (?a ?o ?p ?g ?q ?t)
    :precondition (and (Kin ?a ?o ?p ?g ?q ?t)
                       (AtGrasp ?a ?o ?g) (AtBConf ?q)
                       (not (UnsafePose ?o ?p)))
    :effect (and (AtPose ?o ?p) (HandEmpty ?a) (CanMove)
                 (not (AtGrasp ?a ?o ?g))
                 (increase (total-cost) 1)))

  (:action clean
    :parameters (?o ?s)
    :precondition (and (Stackable ?o ?s) (Sink ?s)
                       (On ?o ?s))
    :effect (and (Cleaned ?o)
                 (increase (total-cost) 1)))

  (:action cook
    :parameters (?o ?s)
    :precondition (and (Stackable ?o ?s) (Stove ?s)
                       (On ?o ?s) (Cleaned ?o))
    :effect (and (Cooked ?o)
                 (not (Cleaned ?o))
                 (increase (total-cost) 1)))

  (:derived (On ?o ?r)
    (exists (?p) (and (Supported ?o ?p ?r)
                      (AtPose ?o ?p))))

  (:derived (Holding ?o)
    (exists (?a ?g) (and (Arm ?a) (Grasp ?o ?g)
                         (AtGrasp ?a ?o ?g))))

  ; placing ?o at ?p would hit an object standing somewhere
  (:derived (UnsafePose ?o ?p)
    (exists (?o2 ?p2) (and (Pose ?o ?p) (Pose ?o2 ?p2) (AtPose ?o2 ?p2)
                           (not (= ?o ?o2))
                           (not (CFreePosePose ?o ?p ?o2 ?p2)))))
) ; kitchen
