; The progress example of paper §VI: a mobile robot must pick object ?o.  Its base motions
; land near, not at, the base pose it aimed for, and the arm's inverse kinematics from a base
; pose succeeds only for some of its random restarts.  Replanning without plan constraints
; may move the base again and again (the paper's oscillation); with them (Algorithm 2), the
; robot keeps the structure [move-base, pick] and picks from where it arrived.
(define (domain progress)
  (:requirements :strips :action-costs)
  (:predicates
    ; static, certified by streams or given
    (graspable ?o) (pose ?o ?p) (grasp ?o ?g) (baseconf ?q) (kin ?o ?p ?g ?q ?aq)
    (motion ?q1 ?t ?q2)
    ; fluents
    (atpose ?o ?p) (atbase ?q) (handempty) (holding ?o))
  (:functions (total-cost) - number)

  (:action move-base
    :parameters (?q1 ?t ?q2)
    :precondition (and (motion ?q1 ?t ?q2) (atbase ?q1))
    :effect (and (atbase ?q2) (not (atbase ?q1)) (increase (total-cost) 5)))

  (:action pick
    :parameters (?o ?p ?g ?q ?aq)
    :precondition (and (kin ?o ?p ?g ?q ?aq) (atpose ?o ?p) (atbase ?q) (handempty))
    :effect (and (holding ?o) (not (atpose ?o ?p)) (not (handempty))
                 (increase (total-cost) 1))))
