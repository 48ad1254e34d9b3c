(define (problem p03-tower) (:domain blocks-4op-variant)
  (:objects c1 c2 c3 c4)
  (:init (arm-empty) (on-table c1) (on c2 c1) (on c3 c2) (clear c3) (on-table c4) (clear c4))
  (:goal (and (on c1 c2) (on c2 c3) (on c3 c4) (on-table c4))))
