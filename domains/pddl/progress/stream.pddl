; Streams of the progress example (paper §VI), implemented in streams/progress.py.
(define (stream progress)
  ; generator, finite: the object's grasps (constants: still valid after any observation)
  (:stream sample-grasp
    :inputs (?o)
    :domain (graspable ?o)
    :outputs (?g)
    :certified (grasp ?o ?g))
  ; generator, endless: base poses within the arm's reach of ?o at ?p
  (:stream inv-reach
    :inputs (?o ?p ?g)
    :domain (and (pose ?o ?p) (grasp ?o ?g))
    :outputs (?q)
    :certified (baseconf ?q))
  ; generator, endless: arm configurations picking ?o from ANY base pose ?q (the reached one
  ; included); each random restart succeeds with probability 0.3 when ?q is within reach
  (:stream inv-kin
    :inputs (?o ?p ?g ?q)
    :domain (and (pose ?o ?p) (grasp ?o ?g) (baseconf ?q))
    :outputs (?aq)
    :certified (kin ?o ?p ?g ?q ?aq))
  ; function, deferrable: a base trajectory (expensive, almost always succeeds: paper §VII)
  (:stream plan-base-motion
    :inputs (?q1 ?q2)
    :domain (and (baseconf ?q1) (baseconf ?q2))
    :outputs (?t)
    :certified (motion ?q1 ?t ?q2)))
