; Block b1 sits in the goal region, which has room for one block only: every placement of b0
; there overlaps b1 (test-cfree fails), so the plan must move b1 out of the way first.
; Poses and configurations (p0, p1, q0) are objects whose values are in streams/tamp2d.py.
(define (problem tamp2d-blocked)
  (:domain tamp2d)
  (:objects b0 b1 p0 p1 q0 rtable rgoal)
  (:init (Block b0) (Block b1) (Region rtable) (Region rgoal)
         (Pose b0 p0) (AtPose b0 p0) (Contained b0 p0 rtable)
         (Pose b1 p1) (AtPose b1 p1) (Contained b1 p1 rgoal)
         (Conf q0) (AtConf q0) (HandEmpty)
         (= (total-cost) 0))
  (:goal (In b0 rgoal))
  (:metric minimize (total-cost)))
