; Robots with suction grippers move blocks along a 2-D ground line (x along the ground, y up).
; Written in the shape of the PDDLStream 2-D continuous TAMP example: untyped, unary predicates
; as types, test predicates used only positively, a forall collision condition on place.
(define (domain pds-tamp2d)
  (:requirements :strips :equality)       ; the body also uses :derived, forall and action costs
  (:predicates
    ; static: certified by streams or given in the init
    (Robot ?r) (Block ?b) (Region ?s)
    (Pose ?b ?p) (Grasp ?b ?g) (Conf ?q) (Traj ?t)
    (Placeable ?b ?s)                       ; ?b may be put down inside ?s
    (Contain ?b ?p ?s)                      ; ?b at ?p lies inside ?s          (test stream)
    (Kin ?b ?q ?p ?g)                       ; gripper at ?q holds ?b at ?p with ?g
    (Motion ?q1 ?t ?q2)                     ; ?t leads from ?q1 to ?q2
    (CFree ?b1 ?p1 ?b2 ?p2)                 ; the two footprints are apart     (test stream)
    ; fluents
    (AtPose ?b ?p) (AtGrasp ?r ?b ?g) (AtConf ?r ?q)
    (HandEmpty ?r) (CanMove ?r)
    ; derived
    (In ?b ?s) (Holding ?r ?b))
  (:functions (Cost) (Dist ?q1 ?q2))

  (:action move
    :parameters (?r ?q1 ?t ?q2)
    :precondition (and (Robot ?r) (Motion ?q1 ?t ?q2)
                       (AtConf ?r ?q1) (CanMove ?r))
    :effect (and (AtConf ?r ?q2)
                 (not (AtConf ?r ?q1)) (not (CanMove ?r))
                 (increase (total-cost) (Dist ?q1 ?q2))))

  (:action pick
    :parameters (?r ?b ?p ?g ?q)
    :precondition (and (Robot ?r) (Kin ?b ?q ?p ?g)
                       (AtConf ?r ?q) (AtPose ?b ?p) (HandEmpty ?r))
    :effect (and (AtGrasp ?r ?b ?g) (CanMove ?r)
                 (not (AtPose ?b ?p)) (not (HandEmpty ?r))
                 (increase (total-cost) (Cost))))

  (:action place
    :parameters (?r ?b ?p ?g ?q)
    :precondition (and (Robot ?r) (Kin ?b ?q ?p ?g)
                       (AtConf ?r ?q) (AtGrasp ?r ?b ?g)
                       ; every block standing somewhere now is clear of the new pose
                       (forall (?b2 ?p2)
                         (imply (and (Pose ?b2 ?p2) (AtPose ?b2 ?p2))
                                (CFree ?b ?p ?b2 ?p2))))
    :effect (and (AtPose ?b ?p) (HandEmpty ?r) (CanMove ?r)
                 (not (AtGrasp ?r ?b ?g))
                 (increase (total-cost) (Cost))))

  (:derived (In ?b ?s)
    (exists (?p) (and (Contain ?b ?p ?s) (AtPose ?b ?p))))

  (:derived (Holding ?r ?b)
    (exists (?g) (and (Robot ?r) (Grasp ?b ?g) (AtGrasp ?r ?b ?g))))
)
