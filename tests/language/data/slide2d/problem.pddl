; object names in mixed case; their values come from VALUES in streams.py
(define (problem Two-Blocks)
  (:domain slide2d)
  (:objects bA bB pA0 pB0 pGoal Left Right)
  (:init (Block bA) (Block bB) (Region Left) (Region Right)
         (Pose bA pA0) (AtPose bA pA0) (Pose bB pB0) (AtPose bB pB0)
         (Pose bA pGoal) (Contain bA pGoal Right)
         (= (Cost) 1) (= (total-cost) 0))
  (:goal (and (AtPose bA pGoal) (In bB Right))))
