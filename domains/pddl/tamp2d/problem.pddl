; Move block b0 from the table into the goal region.
; Poses and configurations are objects named here (p0, q0) whose Python values are in
; VALUES of streams/tamp2d.py, as are the blocks' sizes and the regions' intervals.
(define (problem tamp2d-one)
  (:domain tamp2d)
  (:objects b0 p0 q0 rtable rgoal)
  (:init (Block b0) (Region rtable) (Region rgoal)
         (Pose b0 p0) (AtPose b0 p0) (Contained b0 p0 rtable)
         (Conf q0) (AtConf q0) (HandEmpty)
         (= (total-cost) 0))
  (:goal (In b0 rgoal))
  (:metric minimize (total-cost)))
