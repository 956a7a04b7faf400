; The abstract belief example (paper §IV-A, §V): find a small target that may be hidden
; behind one of two boxes, and pick it.  Beliefs are values: ?pb names a particle pose belief,
; ?obs a hypothesised observation (z, X_i, eps); streams in stream.pddl, implementations in
; streams/belief_detect.py.
(define (domain belief-detect)
  (:requirements :strips :equality :negative-preconditions :existential-preconditions
                 :derived-predicates :action-costs)
  (:predicates
    ; static, certified by streams or given
    (box ?b) (graspable ?o) (uncertain ?o) (poseb ?o ?pb) (obs ?o ?obs) (obsof ?pb ?obs)
    (beliefupdate ?o ?pb1 ?obs ?pb2) (bvis ?o ?obs ?o2 ?pb2)
    (aside ?b ?pb) (localized ?o ?pb)
    ; fluents
    (atposeb ?o ?pb) (handempty) (holding ?o)
    ; derived
    (boccluded ?o ?obs))
  (:functions (obscost ?o ?pb ?obs) (total-cost) - number)

  ; paper §IV-A: an observation is occluded when another object, at its current belief, may
  ; hide its region X_i with probability above eps
  (:derived (boccluded ?o ?obs)
    (exists (?o2 ?pb2)
      (and (obs ?o ?obs) (atposeb ?o2 ?pb2) (not (= ?o ?o2))
           (not (bvis ?o ?obs ?o2 ?pb2)))))

  ; paper §IV-A: the belief update of a hypothesised detection, at the self-loop cost of §V-A
  (:action detect
    :parameters (?o ?pb1 ?obs ?pb2)
    :precondition (and (beliefupdate ?o ?pb1 ?obs ?pb2) (atposeb ?o ?pb1)
                       (not (boccluded ?o ?obs)))
    :effect (and (atposeb ?o ?pb2) (not (atposeb ?o ?pb1))
                 (increase (total-cost) (obscost ?o ?pb1 ?obs))))

  ; move a box out of the camera's way, to a known pose
  (:action move-aside
    :parameters (?b ?pb1 ?pb2)
    :precondition (and (box ?b) (aside ?b ?pb2) (atposeb ?b ?pb1) (handempty))
    :effect (and (atposeb ?b ?pb2) (not (atposeb ?b ?pb1))
                 (increase (total-cost) 2)))

  ; grasping needs a belief precise enough to reach for
  (:action pick
    :parameters (?o ?pb)
    :precondition (and (graspable ?o) (atposeb ?o ?pb) (localized ?o ?pb) (handempty))
    :effect (and (holding ?o) (not (atposeb ?o ?pb)) (not (handempty))
                 (increase (total-cost) 1))))
