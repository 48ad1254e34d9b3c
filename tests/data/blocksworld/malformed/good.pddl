; 4 blocks, seed 11; goal towers (bottom to top): b4; b2; b1 b3
(define (problem bw-4-11)
  (:domain blocksworld)
  (:objects b1 b2 b3 b4)
  (:init
    (handempty)
    (on b2 b4)
    (ontable b1)
    (ontable b3)
    (ontable b4)
    (clear b1)
    (clear b2)
    (clear b3))
  (:goal (and
      (on b3 b1)
      (ontable b1)
      (ontable b2)
      (ontable b4))))
