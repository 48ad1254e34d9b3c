; expect: 3 :5:13: function 'fuel' is not declared
(define (problem two-blocks)
  (:domain place1d)
  (:objects b0 b1 r1 r2 p0 p1 q0)
  (:init (= (fuel b0) 3) (HandEmpty) (Conf q0) (AtConf q0) (Region r1) (Region r2)
         (Block b0) (Pose b0 p0) (AtPose b0 p0)
         (Block b1) (Pose b1 p1) (AtPose b1 p1))
  (:goal (and (In b0 r2) (In b1 r2))))
