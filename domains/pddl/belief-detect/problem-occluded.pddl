; The target is behind box A or behind box B (0.45 each) or on a spot the camera always sees
; (0.10).  Detecting on the visible spot costs 13.7; moving a box (2) and then detecting
; behind it (3.05) is cheaper: the plan moves an occluder before detecting.
(define (problem belief-detect-occluded)
  (:domain belief-detect)
  (:objects target boxa boxb pb-target pb-boxa pb-boxb)
  (:init (graspable target) (uncertain target) (box boxa) (box boxb)
         (poseb target pb-target) (poseb boxa pb-boxa) (poseb boxb pb-boxb)
         (atposeb target pb-target) (atposeb boxa pb-boxa) (atposeb boxb pb-boxb)
         (handempty)
         (= (total-cost) 0))
  (:goal (holding target))
  (:metric minimize (total-cost)))
