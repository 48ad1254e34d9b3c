(define (problem p01-swap) (:domain blocks-4op-variant)
  (:objects a b)
  (:init (arm-empty) (on-table a) (on b a) (clear b))
  (:goal (and (on a b))))
