; Streams of the pds-tamp2d domain; implementations in streams.py, bound by name.
(define (stream pds-tamp2d)
  (:stream sample-pose                      ; poses of ?b inside ?s, clear of fixed obstacles
    :inputs (?b ?s)
    :domain (Placeable ?b ?s)
    :outputs (?p)
    :certified (and (Pose ?b ?p) (Contain ?b ?p ?s)))

  (:stream sample-grasp                     ; suction on the top face, centre first
    :inputs (?b)
    :domain (Block ?b)
    :outputs (?g)
    :certified (Grasp ?b ?g))

  (:stream inverse-kinematics               ; the gripper conf holding ?b at ?p with ?g
    :inputs (?b ?p ?g)
    :domain (and (Pose ?b ?p) (Grasp ?b ?g))
    :outputs (?q)
    :certified (and (Conf ?q) (Kin ?b ?q ?p ?g)))

  (:stream plan-motion                      ; a collision-checked path between two confs
    :inputs (?q1 ?q2)
    :domain (and (Conf ?q1) (Conf ?q2))
    ;:fluents (AtPose AtGrasp)
    :outputs (?t)
    :certified (and (Traj ?t) (Motion ?q1 ?t ?q2)))

  (:stream test-cfree                       ; a test: no outputs
    :inputs (?b1 ?p1 ?b2 ?p2)
    :domain (and (Pose ?b1 ?p1) (Pose ?b2 ?p2))
    :certified (CFree ?b1 ?p1 ?b2 ?p2))

  (:stream test-contain
    :inputs (?b ?p ?s)
    :domain (and (Pose ?b ?p) (Placeable ?b ?s))
    :certified (Contain ?b ?p ?s))

  (:function (Dist ?q1 ?q2)                 ; length of the path plan-motion makes, plus 1
    (and (Conf ?q1) (Conf ?q2)))
)
