; Two routes to the goal: put b0 into the near region or into the far one.  Both satisfy the
; goal; the near one costs less (shorter gripper motions, by the Distance cost function).
; Poses and configurations (p0, q0) are objects whose values are in streams/tamp2d.py.
(define (problem tamp2d-routes)
  (:domain tamp2d-routes)
  (:objects b0 p0 q0 rtable rnear rfar)
  (:init (Block b0) (Region rtable) (Region rnear) (Region rfar)
         (Pose b0 p0) (AtPose b0 p0) (Contained b0 p0 rtable)
         (Conf q0) (AtConf q0) (HandEmpty)
         (= (total-cost) 0))
  (:goal (or (In b0 rfar) (In b0 rnear)))
  (:metric minimize (total-cost)))
