; domain.pddl
(define (domain doors)
  (:requirements :strips :action-costs)
  (:predicates (place ?p) (door ?d ?a ?b) (usable ?d) (opened ?d) (motion ?a ?t ?b) (at ?p))
  (:functions (total-cost) - number)
  (:action open
    :parameters (?d ?a ?b)
    :precondition (and (door ?d ?a ?b) (usable ?d) (at ?a))
    :effect (and (opened ?d) (increase (total-cost) 1)))
  (:action move
    :parameters (?d ?a ?t ?b)
    :precondition (and (door ?d ?a ?b) (opened ?d) (motion ?a ?t ?b) (at ?a))
    :effect (and (at ?b) (not (at ?a)) (increase (total-cost) 2))))
