; The 2-D pick-and-place domain of ../tamp2d (same actions, same streams), for problems whose
; goal can be reached in more than one way at different costs: the move costs come from the
; Distance cost function, so a solver must evaluate it to tell the cheap route from the dear one.
(define (domain tamp2d-routes)
  (:requirements :strips :equality :negative-preconditions :existential-preconditions
                 :disjunctive-preconditions :derived-predicates :action-costs)
  (:predicates
    ; static: certified by streams or given in the problem
    (Block ?b) (Region ?r) (Pose ?b ?p) (Grasp ?b ?g) (Conf ?q) (Traj ?t)
    (Contained ?b ?p ?r)          ; block ?b at pose ?p lies inside region ?r
    (Kin ?b ?p ?g ?q)             ; gripper at ?q holds ?b at ?p with grasp ?g
    (Motion ?q1 ?t ?q2)           ; trajectory ?t leads from ?q1 to ?q2
    (CFree ?b ?p ?b2 ?p2)         ; ?b at ?p and ?b2 at ?p2 do not overlap
    ; fluents
    (AtPose ?b ?p) (AtGrasp ?b ?g) (AtConf ?q) (HandEmpty)
    ; derived
    (Unsafe ?b ?p) (In ?b ?r))
  (:functions (Distance ?q1 ?q2) (total-cost))

  ; Placing ?b at ?p is unsafe when some other block rests where it overlaps ?p.
  ; The solver learns which placements are safe from the test-cfree stream.  (Pose ?b2 ?p2)
  ; holds wherever a block rests; stated beside the test, with the rest of its domain, it lets
  ; the solver state only the pairs that failed and check those a plan relies on.
  (:derived (Unsafe ?b ?p)
    (exists (?b2 ?p2)
      (and (Pose ?b ?p) (AtPose ?b2 ?p2) (Pose ?b2 ?p2) (not (= ?b ?b2))
           (not (CFree ?b ?p ?b2 ?p2)))))

  (:derived (In ?b ?r)
    (exists (?p) (and (Contained ?b ?p ?r) (AtPose ?b ?p))))

  (:action move
    :parameters (?q1 ?t ?q2)
    :precondition (and (Motion ?q1 ?t ?q2) (AtConf ?q1))
    :effect (and (AtConf ?q2) (not (AtConf ?q1))
                 (increase (total-cost) (Distance ?q1 ?q2))))

  (:action pick
    :parameters (?b ?p ?g ?q)
    :precondition (and (Kin ?b ?p ?g ?q) (AtPose ?b ?p) (HandEmpty) (AtConf ?q))
    :effect (and (AtGrasp ?b ?g) (not (AtPose ?b ?p)) (not (HandEmpty))
                 (increase (total-cost) 1)))

  (:action place
    :parameters (?b ?p ?g ?q)
    :precondition (and (Kin ?b ?p ?g ?q) (AtGrasp ?b ?g) (AtConf ?q) (not (Unsafe ?b ?p)))
    :effect (and (AtPose ?b ?p) (HandEmpty) (not (AtGrasp ?b ?g))
                 (increase (total-cost) 1))))
