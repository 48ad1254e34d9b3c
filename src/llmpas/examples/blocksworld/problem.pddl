; 5 blocks, seed 0; goal towers (bottom to top): b4 b3; b1 b2; b5
(define (problem bw-5-0)
  (:domain blocksworld)
  (:objects b1 b2 b3 b4 b5)
  (:init
    (handempty)
    (on b1 b4)
    (on b2 b1)
    (on b4 b5)
    (ontable b3)
    (ontable b5)
    (clear b2)
    (clear b3))
  (:goal (and
      (on b2 b1)
      (on b3 b4)
      (ontable b1)
      (ontable b4)
      (ontable b5))))
