; Same prior for the target, but both boxes stand by the table's edge, out of the camera's
; way: detecting behind where box A or B would stand costs 3.05 and needs no move.
(define (problem belief-detect-clear)
  (:domain belief-detect)
  (:objects target boxa boxb pb-target pb-boxa-clear pb-boxb-clear)
  (:init (graspable target) (uncertain target) (box boxa) (box boxb)
         (poseb target pb-target) (poseb boxa pb-boxa-clear) (poseb boxb pb-boxb-clear)
         (atposeb target pb-target) (atposeb boxa pb-boxa-clear) (atposeb boxb pb-boxb-clear)
         (handempty)
         (= (total-cost) 0))
  (:goal (holding target))
  (:metric minimize (total-cost)))
