(define (stream tamp2d)
  (:stream sample-pose                  ; random placements of ?b inside ?r
    :inputs (?b ?r)
    :domain (Placeable ?b ?r)
    :outputs (?p)
    :certified (and (Pose ?b ?p) (Contain ?b ?p ?r)))

  (:stream inverse-kinematics           ; top grasp: the gripper right above the block
    :inputs (?b ?p)
    :domain (Pose ?b ?p)
    :outputs (?q)
    :certified (and (Conf ?q) (Kin ?b ?p ?q)))

  (:stream plan-motion                  ; up, across at travel height, down
    :inputs (?q1 ?q2)
    :domain (and (Conf ?q1) (Conf ?q2))
    ;:fluents (AtPose)
    :outputs (?t)
    :certified (and (Traj ?t) (Motion ?q1 ?t ?q2)))

  (:stream test-cfree                   ; the two footprints do not overlap
    :inputs (?b1 ?p1 ?b2 ?p2)
    ;:domain (and (Block ?b1) (Block ?b2) (Pose ?b1 ?p1) (Pose ?b2 ?p2))
    :domain (and (Pose ?b1 ?p1) (Pose ?b2 ?p2))
    :certified (CFree ?b1 ?p1 ?b2 ?p2))

  (:function (Dist ?q1 ?q2)             ; length of the trajectory plan-motion makes
    (and (Conf ?q1) (Conf ?q2)))
)
