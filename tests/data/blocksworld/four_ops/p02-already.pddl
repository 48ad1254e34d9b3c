; the goal holds in the initial state: the empty plan is the answer
(define (problem p02-already) (:domain blocks-4op-variant)
  (:objects x y z)
  (:init (arm-empty) (on-table x) (on y x) (clear y) (on-table z) (clear z))
  (:goal (and (on y x) (clear z))))
