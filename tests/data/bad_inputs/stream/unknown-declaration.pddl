; expect: 3 :7:3: expected ':stream', ':function', ':predicate' or ':rule', found ':strem'
(define (stream place1d)
  (:stream sample-pose :inputs (?b ?r) :domain (and (Block ?b) (Region ?r))
    :outputs (?p) :certified (and (Pose ?b ?p) (Contained ?b ?p ?r)))
  (:stream test-cfree :inputs (?b1 ?p1 ?b2 ?p2) :domain (and (Pose ?b1 ?p1) (Pose ?b2 ?p2))
    :certified (CFree ?b1 ?p1 ?b2 ?p2))
  (:strem reach :inputs (?b ?p) :domain (Pose ?b ?p)
    :outputs (?q) :certified (and (Conf ?q) (Reach ?b ?p ?q))))
