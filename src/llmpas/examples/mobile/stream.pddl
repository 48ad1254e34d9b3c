(define (stream mobile-kitchen)
  (:stream sample-pose                    ; a stable placement of ?o on the top of ?r
    :inputs (?o ?r)
    :domain (Stackable ?o ?r)
    :outputs (?p)
    :certified (and (Pose ?o ?p) (Supported ?o ?p ?r)))

  (:stream sample-grasp                   ; top and forward grasps
    :inputs (?o)
    :domain (Object ?o)
    :outputs (?g)
    :certified (Grasp ?o ?g))

  (:stream inverse-kinematics             ; a base pose within reach, and an arm trajectory
    :inputs (?a ?o ?p ?g)
    :domain (and (Arm ?a) (Pose ?o ?p) (Grasp ?o ?g))
    ;:fluents (AtPose)
    :outputs (?q ?t)
    :certified (and (BConf ?q) (ATraj ?t)
                    (Kin ?a ?o ?p ?g ?q ?t)))

  (:stream plan-base-motion               ; a collision-free drive from ?q1 to ?q2
    :inputs (?q1 ?q2)
    :domain (and (BConf ?q1) (BConf ?q2))
    :outputs (?t)
    :certified (and (BTraj ?t) (BaseMotion ?q1 ?t ?q2)))

  (:stream test-cfree-pose-pose           ; footprints of two placed objects do not overlap
    :inputs (?o1 ?p1 ?o2 ?p2)
    :domain (and (Pose ?o1 ?p1) (Pose ?o2 ?p2))
    :certified (CFreePosePose ?o1 ?p1 ?o2 ?p2))

  (:function (Distance ?q1 ?q2)
    (and (BConf ?q1) (BConf ?q2)))
)
