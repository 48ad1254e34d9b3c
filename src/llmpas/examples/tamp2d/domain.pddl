; A gripper above a long 1-D table moves blocks of different widths between
; intervals of the table (regions). Poses, confs and trajectories come from streams.
(define (domain tamp2d)
  (:requirements :strips :equality)   ; the body also uses :derived and action costs
  (:predicates
    (Block ?b) (Region ?r)              ; unary predicates act as types
    (Conf ?q) (Traj ?t)
    (Pose ?b ?p)
    (Placeable ?b ?r)                   ; ?b may be put down in ?r
    (Contain ?b ?p ?r)                  ; ?b at ?p lies inside ?r
    (Kin ?b ?p ?q)                      ; gripper at ?q holds ?b at ?p
    (Motion ?q1 ?t ?q2)
    (CFree ?b1 ?p1 ?b2 ?p2)             ; certified by the test stream
    (AtPose ?b ?p) (AtConf ?q) (Holding ?b)
    (HandEmpty) (CanMove)
    (In ?b ?r) (Unsafe ?b ?p))
  (:functions (Dist ?q1 ?q2) (total-cost))

  (:action move
    :parameters (?q1 ?t ?q2)
    :precondition (and (Motion ?q1 ?t ?q2)
                       (AtConf ?q1) (CanMove))
    :effect (and (AtConf ?q2)
                 (not (AtConf ?q1)) (not (CanMove))
                 (increase (total-cost) (Dist ?q1 ?q2))))

  (:action pick
    :parameters (?b ?p ?q)
    :precondition (and (Kin ?b ?p ?q)
                       (AtPose ?b ?p) (HandEmpty) (AtConf ?q))
    :effect (and (Holding ?b) (CanMove)
                 (not (AtPose ?b ?p)) (not (HandEmpty))
                 (increase (total-cost) 1)))

  (:action place
    :parameters (?b ?p ?q)
    :precondition (and (Kin ?b ?p ?q)
                       (Holding ?b) (AtConf ?q)
                       (not (Unsafe ?b ?p)))     ; nothing else overlaps ?p
    :effect (and (AtPose ?b ?p) (HandEmpty) (CanMove)
                 (not (Holding ?b))
                 (increase (total-cost) 1)))

  (:derived (In ?b ?r)
    (exists (?p) (and (Contain ?b ?p ?r)
                      (AtPose ?b ?p))))

  ; ?p overlaps a block that is on the table now: the test rejected the pair
  (:derived (Unsafe ?b ?p)
    (exists (?b2 ?p2) (and (Pose ?b ?p) (Pose ?b2 ?p2) (AtPose ?b2 ?p2)
                           (not (= ?b ?b2))
                           (not (CFree ?b ?p ?b2 ?p2)))))
)
