; The kitchen of the paper's experiments (§IV, §IV-A, §V, §VIII, appendix) in belief space.
; Robot parts: base (x, y, yaw) and arm (7 joints).  Every object's pose is a belief (a
; particle distribution, streams/belief.py); beliefs of objects in a drawer are relative to the
; drawer, so they move with it and pull/push need no effect on them.  Drawers take two angles
; (open, closed).  Streams in stream.pddl, implementations in streams/kitchen_module.py.
(define (domain kitchen)
  (:requirements :strips :equality :negative-preconditions :existential-preconditions
                 :universal-preconditions :disjunctive-preconditions :conditional-effects
                 :derived-predicates :action-costs)
  (:constants base arm stove)
  (:predicates
    ; static: given in the problem
    (graspable ?o) (tall ?o) (surface ?s) (fixed ?s) (drawer ?d) (placeable ?o ?s)
    (hasbutton ?s)                    ; the stove's on/off button is pressed from a pressbase
    (angle ?d ?a) (open ?d ?a) (closed ?d ?a) (above ?d1 ?d2)
    (stow ?q) (stowempty ?q) (stowheld ?q)
    (reached ?q)                      ; the robot is at configuration ?q (base, arm)
    (near ?bq ?x)                     ; at reached base ?bq the arm may reach surface/drawer ?x
    (possible ?o ?pb ?s)              ; prior belief ?pb may put ?o on ?s (sample-obs there)
    (current ?o ?pb)                  ; ?pb is ?o's belief now (not a placement to come)
    ; static: certified by streams
    (conf ?r ?q) (traj ?r ?t) (poseb ?o ?pb) (grasp ?o ?g)
    (localized ?o ?pb)                ; ?pb is precise enough to grasp from
    (anybase ?o ?pb)                  ; bases are sampled for ?pb (not only the reached one)
    (beliefon ?o ?pb ?s)              ; ?pb puts ?o on ?s (with high probability)
    (basefor ?o ?pb ?g ?bq)           ; from ?bq, the arm may reach ?o at ?pb with ?g
    (kin ?o ?pb ?g ?bq ?aq ?t)        ; at ?bq, ?t approaches ?o at ?pb with ?g from arm conf ?aq
    (reach ?bq ?aq)                   ; arm conf ?aq is used at base conf ?bq
    (motion ?r ?q1 ?t ?q2)            ; base trajectory ?t from ?q1 to ?q2
    (armmotion ?bq ?q1 ?t ?q2)        ; arm trajectory ?t from ?q1 to ?q2 at base conf ?bq
    (drawerbase ?d ?bq) (drawerkin ?d ?a1 ?a2 ?bq ?aq1 ?aq2 ?t)
    (pressbase ?bq) (presskin ?bq ?aq ?t)
    (obs ?o ?obs) (obsof ?pb ?obs) (obson ?obs ?s)
    (beliefupdate ?o ?pb1 ?obs ?pb2)
    (bvis ?o ?obs ?o2 ?pb2)           ; ?o2 at ?pb2 leaves ?obs's region visible (paper §IV-A)
    (bvisrobot ?o ?obs ?bq)           ; so does the robot at ?bq with its arm stowed
    (cfree ?o ?pb ?o2 ?pb2)
    (afree ?bq ?aq ?o2 ?pb2)          ; the arm at ?aq (base ?bq) is clear of ?o2 at ?pb2
    ; fluents
    (atconf ?r ?q) (atangle ?d ?a) (handempty) (atgrasp ?o ?g) (atposeb ?o ?pb)
    (cooked ?o) (stoveon)
    ; derived
    (boccluded ?o ?obs) (armstowed) (accessible ?o ?pb) (blocked ?d) (covered ?d) (unsafe ?o ?pb)
    (armblocked ?o ?bq ?aq)
    (on ?o ?s))
  (:functions (obscost ?o ?pb ?obs) (total-cost) - number)

  ; paper §IV-A: the region of ?obs may be hidden by another object's belief, by the robot,
  ; by the drawer holding it being closed or by an open drawer above that one.  Every disjunct
  ; binds ?o through (obs ?o ?obs): a disjunct without it is grounded over every object (22,540
  ; atoms on one Swap replan, two thirds of Fast Downward's translation time)
  (:derived (boccluded ?o ?obs)
    (or (exists (?o2 ?pb2)
          (and (obs ?o ?obs) (atposeb ?o2 ?pb2) (not (= ?o ?o2))
               (not (bvis ?o ?obs ?o2 ?pb2))))
        (exists (?bq)
          (and (obs ?o ?obs) (atconf base ?bq) (not (bvisrobot ?o ?obs ?bq))))
        (exists (?d ?a)
          (and (obs ?o ?obs) (obson ?obs ?d) (atangle ?d ?a) (closed ?d ?a)))
        (exists (?d ?d2 ?a)
          (and (obs ?o ?obs) (obson ?obs ?d2) (above ?d ?d2) (atangle ?d ?a) (open ?d ?a)))))

  ; the arm is tucked (hand empty) or in its carry configuration (holding)
  (:derived (armstowed)
    (exists (?q)
      (and (atconf arm ?q)
           (or (and (handempty) (stowempty ?q))
               (and (not (handempty)) (stowheld ?q))))))

  ; ?o at ?pb can be reached: on a fixed surface or in an open drawer
  (:derived (accessible ?o ?pb)
    (or (exists (?s) (and (beliefon ?o ?pb ?s) (fixed ?s)))
        (exists (?d ?a) (and (beliefon ?o ?pb ?d) (atangle ?d ?a) (open ?d ?a)
                             (not (covered ?d))))))

  ; another drawer is open: the arm reaches into ?d, or moves its handle, only with the other
  ; drawers closed, as the streams plan those motions (an open drawer above overhangs ?d; an
  ; open one below keeps the base from the front of ?d: with the bottom drawer open, Swap seed
  ; 2 found no base for the block in the top one, and no plan closed the bottom one first)
  (:derived (covered ?d)
    (exists (?d2 ?a) (and (drawer ?d) (drawer ?d2) (not (= ?d2 ?d)) (atangle ?d2 ?a)
                          (open ?d2 ?a))))

  ; a tall object in a drawer keeps it from closing
  (:derived (blocked ?d)
    (exists (?o ?pb) (and (drawer ?d) (tall ?o) (atposeb ?o ?pb) (beliefon ?o ?pb ?d))))

  ; placing ?o at ?pb may collide with another object at its current belief
  ; (the domain of test-cfree beside the test: where it holds, the solver states cfree's
  ; failures alone and checks the pairs a plan relies on -- compile/lazy_tests.py; every
  ; pose placed at is localized, every pose an object is at is a poseb)
  (:derived (unsafe ?o ?pb)
    (exists (?o2 ?pb2)
      (and (poseb ?o ?pb) (localized ?o ?pb) (atposeb ?o2 ?pb2) (poseb ?o2 ?pb2)
           (not (= ?o ?o2)) (not (cfree ?o ?pb ?o2 ?pb2)))))

  ; the arm configuration from which ?o is picked or placed may be inside another object at
  ; its current belief (the approach starts there; inv-kin checks only what the robot put
  ; down itself, as plans often move the rest first -- Cook seed 2 drove between bases near
  ; the block some 50 times, the block's pre-grasp inside the sugar box from each, until the
  ; planner could see why and move the box first or grasp from elsewhere)
  (:derived (armblocked ?o ?bq ?aq)
    (exists (?o2 ?pb2)
      (and (graspable ?o) (reach ?bq ?aq) (atposeb ?o2 ?pb2) (poseb ?o2 ?pb2) (not (= ?o ?o2))
           (not (afree ?bq ?aq ?o2 ?pb2)))))

  ; the robot believes ?o is on ?s, precisely enough to act on it
  (:derived (on ?o ?s)
    (exists (?pb) (and (atposeb ?o ?pb) (localized ?o ?pb) (beliefon ?o ?pb ?s))))

  (:action move-base
    :parameters (?q1 ?t ?q2)
    :precondition (and (motion base ?q1 ?t ?q2) (atconf base ?q1) (armstowed))
    :effect (and (atconf base ?q2) (not (atconf base ?q1))
                 (increase (total-cost) 1)))

  (:action move-arm
    :parameters (?bq ?q1 ?t ?q2)
    :precondition (and (armmotion ?bq ?q1 ?t ?q2) (atconf base ?bq) (atconf arm ?q1)
                       (or (handempty) (not (stowempty ?q2))))  ; tuck: the empty hand's stow
    :effect (and (atconf arm ?q2) (not (atconf arm ?q1))
                 (increase (total-cost) 1)))

  (:action pick
    :parameters (?o ?pb ?g ?bq ?aq ?t)
    :precondition (and (kin ?o ?pb ?g ?bq ?aq ?t) (atposeb ?o ?pb) (handempty)
                       (accessible ?o ?pb) (not (armblocked ?o ?bq ?aq))
                       (atconf base ?bq) (atconf arm ?aq))
    :effect (and (atgrasp ?o ?g) (not (atposeb ?o ?pb)) (not (handempty))
                 (increase (total-cost) 1)))

  (:action place
    :parameters (?o ?pb ?g ?bq ?aq ?t)
    :precondition (and (kin ?o ?pb ?g ?bq ?aq ?t) (atgrasp ?o ?g) (accessible ?o ?pb)
                       (not (unsafe ?o ?pb)) (not (armblocked ?o ?bq ?aq))
                       (atconf base ?bq) (atconf arm ?aq))
    :effect (and (atposeb ?o ?pb) (handempty) (not (atgrasp ?o ?g))
                 (increase (total-cost) 1)))

  (:action pull
    :parameters (?d ?a1 ?a2 ?bq ?aq1 ?aq2 ?t)
    :precondition (and (drawerkin ?d ?a1 ?a2 ?bq ?aq1 ?aq2 ?t) (closed ?d ?a1) (open ?d ?a2)
                       (atangle ?d ?a1) (not (covered ?d)) (handempty)
                       (atconf base ?bq) (atconf arm ?aq1))
    :effect (and (atangle ?d ?a2) (not (atangle ?d ?a1))
                 (atconf arm ?aq2) (not (atconf arm ?aq1))
                 (increase (total-cost) 1)))

  (:action push
    :parameters (?d ?a1 ?a2 ?bq ?aq1 ?aq2 ?t)
    :precondition (and (drawerkin ?d ?a1 ?a2 ?bq ?aq1 ?aq2 ?t) (open ?d ?a1) (closed ?d ?a2)
                       (atangle ?d ?a1) (not (blocked ?d)) (not (covered ?d)) (handempty)
                       (atconf base ?bq) (atconf arm ?aq1))
    :effect (and (atangle ?d ?a2) (not (atangle ?d ?a1))
                 (atconf arm ?aq2) (not (atconf arm ?aq1))
                 (increase (total-cost) 1)))

  ; turning the stove on cooks what the robot believes is on it (the derived ``on``: one
  ; quantified variable, not two -- a translator enumerates every object for each variable of
  ; a universal effect, so (forall (?o ?pb) ...) cost it the square of the objects)
  (:action press-on
    :parameters (?bq ?aq ?t)
    :precondition (and (presskin ?bq ?aq ?t) (not (stoveon)) (handempty)
                       (atconf base ?bq) (atconf arm ?aq))
    :effect (and (stoveon)
                 (forall (?o) (when (on ?o stove) (cooked ?o)))
                 (increase (total-cost) 1)))

  (:action press-off
    :parameters (?bq ?aq ?t)
    :precondition (and (presskin ?bq ?aq ?t) (stoveon) (handempty)
                       (atconf base ?bq) (atconf arm ?aq))
    :effect (and (not (stoveon)) (increase (total-cost) 1)))

  ; paper §IV-A: the belief update of a hypothesised detection, at the cost of §V.  The hand is
  ; empty and the arm tucked, the robot as test-vis-robot sees it: a held box in front of the
  ; camera hid the block from every detection of Cook seed 3, which the planner, blind to what
  ; the robot holds, chose again and again (the paper's detect does not ask for an empty hand)
  (:action detect
    :parameters (?o ?pb1 ?obs ?pb2)
    :precondition (and (beliefupdate ?o ?pb1 ?obs ?pb2) (atposeb ?o ?pb1) (armstowed)
                       (handempty) (not (boccluded ?o ?obs)))
    :effect (and (atposeb ?o ?pb2) (not (atposeb ?o ?pb1))
                 (increase (total-cost) (obscost ?o ?pb1 ?obs)))))
