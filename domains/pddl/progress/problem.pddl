; The robot stands at q0, two metres from the object; it must hold it.
(define (problem progress-pick)
  (:domain progress)
  (:objects d p-d q0)
  (:init (graspable d) (pose d p-d) (atpose d p-d) (baseconf q0) (atbase q0) (handempty)
         (= (total-cost) 0))
  (:goal (holding d))
  (:metric minimize (total-cost)))
