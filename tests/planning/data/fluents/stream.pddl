(define (stream stack)
  (:stream grasp
    :inputs (?b)
    :domain (Block ?b)
    :fluents (On)          ; the blocks where they are when the grasp is used
    :outputs (?g)
    :certified (Grasp ?b ?g)))
