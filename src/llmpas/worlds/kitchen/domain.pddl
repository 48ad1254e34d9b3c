; A household: a mobile manipulator picks and places objects between tables, drawers, appliances
; and a bowl, looks under covers, and cleans, cooks, heats and cools food.
; Geometry (base poses, reachability, base motions) comes from streams; Kin, BaseMotion and View
; are deferred to execution by default.
(define (domain household)
  (:requirements :strips :equality)     ; lax, as wild files are: derived predicates, costs
  (:predicates
    (Object ?o) (Region ?r) (Surface ?r) (Drawer ?r) (Openable ?r) (Cover ?c)
    (Sink ?r) (Stove ?r) (Microwave ?r) (Fridge ?r) (Single ?r)   ; Single: room for one object
    (Stackable ?o ?r)
    (Pose ?o ?p) (Supported ?o ?p ?r) (AtPose ?o ?p)
    (Grasp ?o ?g) (AtGrasp ?o ?g) (HandEmpty)
    (BConf ?q) (AtBConf ?q) (CanMove)
    (Kin ?o ?p ?g ?q)                   ; from base ?q the arm reaches ?o at ?p with grasp ?g
    (BaseMotion ?q1 ?t ?q2)             ; a collision-free drive
    (View ?r ?q)                        ; from base ?q the robot sees (and reaches) region ?r
    (CFree ?o ?p ?o2 ?p2)               ; footprints do not overlap
    (Open ?r)
    (Dirty ?o) (Cleaned ?o) (Cooked ?o) (Heated ?o) (Cooled ?o)
    (Scanned ?r))
  (:functions (Distance ?q1 ?q2))

  (:derived (On ?o ?r) (exists (?p) (and (Supported ?o ?p ?r) (AtPose ?o ?p))))
  (:derived (Holding ?o) (exists (?g) (and (Grasp ?o ?g) (AtGrasp ?o ?g))))
  (:derived (Accessible ?r) (and (Region ?r) (or (not (Openable ?r)) (Open ?r))))
  (:derived (Full ?r) (exists (?o) (and (Single ?r) (On ?o ?r))))
  (:derived (UnsafePose ?o ?p)
    (exists (?o2 ?p2) (and (Pose ?o ?p) (Pose ?o2 ?p2) (AtPose ?o2 ?p2) (not (= ?o ?o2))
                           (not (CFree ?o ?p ?o2 ?p2)))))

  (:action move_base
    :parameters (?q1 ?q2 ?t)
    :precondition (and (BaseMotion ?q1 ?t ?q2) (AtBConf ?q1) (CanMove))
    :effect (and (AtBConf ?q2) (not (AtBConf ?q1)) (not (CanMove))
                 (increase (total-cost) (Distance ?q1 ?q2))))

  (:action pick
    :parameters (?o ?p ?r ?g ?q)
    :precondition (and (Kin ?o ?p ?g ?q) (Supported ?o ?p ?r) (AtPose ?o ?p) (HandEmpty)
                       (AtBConf ?q) (Accessible ?r))
    :effect (and (AtGrasp ?o ?g) (CanMove) (not (AtPose ?o ?p)) (not (HandEmpty))
                 (increase (total-cost) 1)))

  (:action place
    :parameters (?o ?p ?r ?g ?q)
    :precondition (and (Kin ?o ?p ?g ?q) (Supported ?o ?p ?r) (AtGrasp ?o ?g) (AtBConf ?q)
                       (Accessible ?r) (not (Full ?r)) (not (UnsafePose ?o ?p)))
    :effect (and (AtPose ?o ?p) (HandEmpty) (CanMove) (not (AtGrasp ?o ?g))
                 (increase (total-cost) 1)))

  (:action scan_table
    :parameters (?r ?q)
    :precondition (and (Surface ?r) (View ?r ?q) (AtBConf ?q))
    :effect (and (Scanned ?r) (CanMove) (increase (total-cost) 1)))

  (:action scan_drawer
    :parameters (?r ?q)
    :precondition (and (Drawer ?r) (Open ?r) (View ?r ?q) (AtBConf ?q))
    :effect (and (Scanned ?r) (CanMove) (increase (total-cost) 1)))

  (:action scan_cover                   ; lift the cover, look under it, put it back
    :parameters (?c ?p ?r ?g ?q)
    :precondition (and (Cover ?c) (Kin ?c ?p ?g ?q) (Supported ?c ?p ?r) (AtPose ?c ?p)
                       (HandEmpty) (AtBConf ?q))
    :effect (and (Scanned ?c) (CanMove) (increase (total-cost) 1)))

  (:action open
    :parameters (?r ?q)
    :precondition (and (Openable ?r) (View ?r ?q) (AtBConf ?q) (HandEmpty) (not (Open ?r)))
    :effect (and (Open ?r) (CanMove) (increase (total-cost) 1)))

  (:action close
    :parameters (?r ?q)
    :precondition (and (Openable ?r) (View ?r ?q) (AtBConf ?q) (HandEmpty) (Open ?r))
    :effect (and (not (Open ?r)) (CanMove) (increase (total-cost) 1)))

  (:action clean
    :parameters (?o ?r)
    :precondition (and (Sink ?r) (On ?o ?r))
    :effect (and (Cleaned ?o) (not (Dirty ?o)) (increase (total-cost) 1)))

  (:action cook
    :parameters (?o ?r)
    :precondition (and (Stove ?r) (On ?o ?r) (not (Dirty ?o)))
    :effect (and (Cooked ?o) (increase (total-cost) 1)))

  (:action heat
    :parameters (?o ?r)
    :precondition (and (Microwave ?r) (On ?o ?r) (not (Open ?r)))
    :effect (and (Heated ?o) (increase (total-cost) 1)))

  (:action cool
    :parameters (?o ?r)
    :precondition (and (Fridge ?r) (On ?o ?r) (not (Open ?r)) (not (Dirty ?o)))
    :effect (and (Cooled ?o) (increase (total-cost) 1)))
)
