(define (stream household)
  (:stream sample-pose                  ; a free spot for ?o in region ?r
    :inputs (?o ?r)
    :domain (Stackable ?o ?r)
    :outputs (?p)
    :certified (and (Pose ?o ?p) (Supported ?o ?p ?r)))

  (:stream sample-grasp                 ; top or forward grasp
    :inputs (?o)
    :domain (Object ?o)
    :outputs (?g)
    :certified (Grasp ?o ?g))

  (:stream inverse-kinematics           ; a base pose from which the arm reaches ?o at ?p
    :inputs (?o ?p ?g)
    :domain (and (Pose ?o ?p) (Grasp ?o ?g))
    :outputs (?q)
    :certified (and (BConf ?q) (Kin ?o ?p ?g ?q)))

  (:stream sample-view                  ; a base pose facing region ?r, within reach of it
    :inputs (?r)
    :domain (Region ?r)
    :outputs (?q)
    :certified (and (BConf ?q) (View ?r ?q)))

  (:stream plan-base-motion             ; a collision-free drive
    :inputs (?q1 ?q2)
    :domain (and (BConf ?q1) (BConf ?q2))
    :outputs (?t)
    :certified (BaseMotion ?q1 ?t ?q2))

  (:stream test-cfree                   ; two placed footprints do not overlap
    :inputs (?o ?p ?o2 ?p2)
    :domain (and (Pose ?o ?p) (Pose ?o2 ?p2))
    :certified (CFree ?o ?p ?o2 ?p2))

  (:function (Distance ?q1 ?q2)
    (and (BConf ?q1) (BConf ?q2)))
)
