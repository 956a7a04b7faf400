; stream.pddl
(define (stream doors)
  (:stream plan-motion
    :inputs (?a ?b)
    :domain (and (place ?a) (place ?b))
    :outputs (?t)
    :certified (motion ?a ?t ?b)))
