; Streams of the abstract belief example (paper §IV-A, §V); none is deferrable: all are cheap.
(define (stream belief-detect)
  ; observations (z, X_i, eps) of ?o under ?pb: X_i is a region of ?pb's particles.  Only
  ; objects whose pose is uncertain are looked for (the boxes' poses are known).
  (:stream sample-obs
    :inputs (?o ?pb)
    :domain (and (uncertain ?o) (poseb ?o ?pb))
    :outputs (?obs)
    :certified (and (obs ?o ?obs) (obsof ?pb ?obs)))
  ; the posterior of ?pb1 assuming ?obs, an observation sampled from ?pb1, is received (a
  ; function of its inputs).  (obsof ?pb1 ?obs) keeps the planner from applying an observation
  ; made for one belief to another: a fresh optimistic belief would otherwise give it fresh
  ; optimistic observations at every level.
  (:stream update-belief
    :inputs (?o ?pb1 ?obs)
    :domain (and (poseb ?o ?pb1) (obs ?o ?obs) (obsof ?pb1 ?obs))
    :outputs (?pb2)
    :certified (and (poseb ?o ?pb2) (beliefupdate ?o ?pb1 ?obs ?pb2)))
  ; ?o2 at ?pb2 leaves the region of ?obs visible with probability at least 1 - eps
  (:stream test-vis
    :inputs (?o ?obs ?o2 ?pb2)
    :domain (and (obs ?o ?obs) (poseb ?o2 ?pb2))
    :certified (bvis ?o ?obs ?o2 ?pb2))
  ; known poses of a box out of the camera's way
  (:stream sample-aside
    :inputs (?b)
    :domain (box ?b)
    :outputs (?pb)
    :certified (and (poseb ?b ?pb) (aside ?b ?pb)))
  ; the belief is precise enough to grasp from
  (:stream test-localized
    :inputs (?o ?pb)
    :domain (and (graspable ?o) (poseb ?o ?pb))
    :certified (localized ?o ?pb))
  ; paper §V: self-loop determinized cost of detect, from the lower bound of eq. 2
  (:function (obscost ?o ?pb ?obs)
    (and (poseb ?o ?pb) (obs ?o ?obs))))
