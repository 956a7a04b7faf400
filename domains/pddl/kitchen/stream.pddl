; Streams of the kitchen domain (paper §IV, §IV-A, §V), implemented in
; streams/kitchen_module.py over the geometric streams of streams/kitchen.py.  Motions are
; deferrable (paper §VII): they are expensive and almost always succeed.
(define (stream kitchen)
  ; grasps of an object (top and side), finite
  (:stream sample-grasp
    :inputs (?o)
    :domain (graspable ?o)
    :outputs (?g)
    :certified (grasp ?o ?g))
  ; stable, collision-free placements of ?o on ?s: known poses (point beliefs)
  (:stream sample-placement
    :inputs (?o ?s)
    :domain (placeable ?o ?s)
    :outputs (?pb)
    :certified (and (poseb ?o ?pb) (localized ?o ?pb) (beliefon ?o ?pb ?s) (anybase ?o ?pb)))
  ; base configurations from which ?o at ?pb can be grasped with ?g (not for placements
  ; sampled from the reached base: those are reached from there, and a base sampled for each
  ; of them, times each grasp, squared by the base motions between them, made constrained
  ; replans of Swap 18 times larger than unconstrained ones at the same level)
  (:stream inv-reach
    :inputs (?o ?pb ?g)
    :domain (and (localized ?o ?pb) (anybase ?o ?pb) (grasp ?o ?g))
    :outputs (?bq)
    :certified (and (conf base ?bq) (basefor ?o ?pb ?g ?bq)))
  ; the pre-grasp arm configuration and the approach path (function)
  (:stream inv-kin
    :inputs (?o ?pb ?g ?bq)
    :domain (basefor ?o ?pb ?g ?bq)
    :outputs (?aq ?t)
    :certified (and (conf arm ?aq) (traj arm ?t) (reach ?bq ?aq) (kin ?o ?pb ?g ?bq ?aq ?t)))
  ; RRT-Connect for the base (deferrable)
  (:stream plan-base-motion
    :inputs (?q1 ?q2)
    :domain (and (conf base ?q1) (conf base ?q2))
    :outputs (?t)
    :certified (and (traj base ?t) (motion base ?q1 ?t ?q2)))
  ; RRT-Connect for the arm between a stowed configuration and one used at ?bq, both ways
  ; (deferrable)
  (:stream plan-arm-motion
    :inputs (?bq ?q1 ?q2)
    :domain (and (stow ?q1) (reach ?bq ?q2))
    :outputs (?t)
    :certified (and (traj arm ?t) (armmotion ?bq ?q1 ?t ?q2) (armmotion ?bq ?q2 ?t ?q1)))
  ; base configurations from which a drawer's handle can be reached over its whole travel
  (:stream sample-drawer-base
    :inputs (?d)
    :domain (drawer ?d)
    :outputs (?bq)
    :certified (and (conf base ?bq) (drawerbase ?d ?bq)))
  ; approach the handle, pull it open, retreat (function)
  (:stream plan-pull
    :inputs (?d ?a1 ?a2 ?bq)
    :domain (and (drawerbase ?d ?bq) (closed ?d ?a1) (open ?d ?a2))
    :outputs (?aq1 ?aq2 ?t)
    :certified (and (conf arm ?aq1) (conf arm ?aq2) (reach ?bq ?aq1) (reach ?bq ?aq2)
                    (drawerkin ?d ?a1 ?a2 ?bq ?aq1 ?aq2 ?t)))
  ; approach the handle, push it closed, retreat (function)
  (:stream plan-push
    :inputs (?d ?a1 ?a2 ?bq)
    :domain (and (drawerbase ?d ?bq) (open ?d ?a1) (closed ?d ?a2))
    :outputs (?aq1 ?aq2 ?t)
    :certified (and (conf arm ?aq1) (conf arm ?aq2) (reach ?bq ?aq1) (reach ?bq ?aq2)
                    (drawerkin ?d ?a1 ?a2 ?bq ?aq1 ?aq2 ?t)))
  ; base configurations from which the stove's button can be pressed
  (:stream sample-press-base
    :inputs (?s)
    :domain (hasbutton ?s)
    :outputs (?bq)
    :certified (and (conf base ?bq) (pressbase ?bq)))
  ; the approach path to the button (function)
  (:stream plan-press
    :inputs (?bq)
    :domain (pressbase ?bq)
    :outputs (?aq ?t)
    :certified (and (conf arm ?aq) (reach ?bq ?aq) (presskin ?bq ?aq ?t)))
  ; act from where the robot is (issue 11): the same kinematics from the base configuration
  ; the robot reached (no sampler certified it), when they allow -- only for what is near it
  ; (a surface, drawer or the stove within the arm's reach: else every belief of every object
  ; would be tried from there, and fail)
  (:stream inv-kin-here
    :inputs (?o ?pb ?g ?bq ?s)
    :domain (and (localized ?o ?pb) (current ?o ?pb) (beliefon ?o ?pb ?s) (grasp ?o ?g)
                 (conf base ?bq) (reached ?bq) (near ?bq ?s))
    :outputs (?aq ?t)
    :certified (and (conf arm ?aq) (traj arm ?t) (reach ?bq ?aq) (kin ?o ?pb ?g ?bq ?aq ?t)))
  (:stream plan-pull-here
    :inputs (?d ?a1 ?a2 ?bq)
    :domain (and (conf base ?bq) (reached ?bq) (near ?bq ?d) (closed ?d ?a1) (open ?d ?a2))
    :outputs (?aq1 ?aq2 ?t)
    :certified (and (conf arm ?aq1) (conf arm ?aq2) (reach ?bq ?aq1) (reach ?bq ?aq2)
                    (drawerkin ?d ?a1 ?a2 ?bq ?aq1 ?aq2 ?t)))
  (:stream plan-push-here
    :inputs (?d ?a1 ?a2 ?bq)
    :domain (and (conf base ?bq) (reached ?bq) (near ?bq ?d) (open ?d ?a1) (closed ?d ?a2))
    :outputs (?aq1 ?aq2 ?t)
    :certified (and (conf arm ?aq1) (conf arm ?aq2) (reach ?bq ?aq1) (reach ?bq ?aq2)
                    (drawerkin ?d ?a1 ?a2 ?bq ?aq1 ?aq2 ?t)))
  (:stream plan-press-here
    :inputs (?bq)
    :domain (and (conf base ?bq) (reached ?bq) (near ?bq stove))
    :outputs (?aq ?t)
    :certified (and (conf arm ?aq) (reach ?bq ?aq) (presskin ?bq ?aq ?t)))
  ; ... and from the arm configuration the robot is in (after an arm motion): the action
  ; starts there, no arm motion first
  (:stream inv-kin-from
    :inputs (?o ?pb ?g ?bq ?aq ?s)
    :domain (and (localized ?o ?pb) (current ?o ?pb) (beliefon ?o ?pb ?s) (grasp ?o ?g)
                 (reached ?bq) (near ?bq ?s) (conf arm ?aq) (reached ?aq))
    :outputs (?t)
    :certified (and (traj arm ?t) (kin ?o ?pb ?g ?bq ?aq ?t)))
;   inv-kin-here and inv-kin-from pick an object from where it is now (``current``); a
  ; placement from here is sampled in reach with its approach (sample-placement-here), or is
  ; where the held object lands from the arm configuration the robot is in (place-from)
  (:stream sample-placement-here
    :inputs (?o ?s ?g ?bq)
    :domain (and (placeable ?o ?s) (grasp ?o ?g) (conf base ?bq) (reached ?bq) (near ?bq ?s))
    :outputs (?pb ?aq ?t)
    :certified (and (poseb ?o ?pb) (localized ?o ?pb) (beliefon ?o ?pb ?s) (conf arm ?aq)
                    (traj arm ?t) (reach ?bq ?aq) (kin ?o ?pb ?g ?bq ?aq ?t)))
  (:stream place-from
    :inputs (?o ?g ?bq ?aq ?s)
    :domain (and (placeable ?o ?s) (grasp ?o ?g) (reached ?bq) (near ?bq ?s) (conf arm ?aq)
                 (reached ?aq))
    :outputs (?pb ?t)
    :certified (and (poseb ?o ?pb) (localized ?o ?pb) (beliefon ?o ?pb ?s) (traj arm ?t)
                    (kin ?o ?pb ?g ?bq ?aq ?t)))
  ; ... and an arm motion from the configuration the arm is in to one used at the reached base,
  ; with no stowed configuration between (deferrable).  Holding an object, the arm can only go
  ; back to carry otherwise: Cook seed 9 stopped short of carry holding the sugar box (the true
  ; world refused the rest), every motion back to carry failed, and no plan was left.
  (:stream plan-arm-motion-from
    :inputs (?bq ?q1 ?q2)
    :domain (and (reached ?bq) (conf arm ?q1) (reached ?q1) (reach ?bq ?q2))
    :outputs (?t)
    :certified (and (traj arm ?t) (armmotion ?bq ?q1 ?t ?q2)))
  (:stream plan-pull-from
    :inputs (?d ?a1 ?a2 ?bq ?aq1)
    :domain (and (reached ?bq) (near ?bq ?d) (conf arm ?aq1) (reached ?aq1) (closed ?d ?a1)
                 (open ?d ?a2))
    :outputs (?aq2 ?t)
    :certified (and (conf arm ?aq2) (reach ?bq ?aq2) (drawerkin ?d ?a1 ?a2 ?bq ?aq1 ?aq2 ?t)))
  (:stream plan-push-from
    :inputs (?d ?a1 ?a2 ?bq ?aq1)
    :domain (and (reached ?bq) (near ?bq ?d) (conf arm ?aq1) (reached ?aq1) (open ?d ?a1)
                 (closed ?d ?a2))
    :outputs (?aq2 ?t)
    :certified (and (conf arm ?aq2) (reach ?bq ?aq2) (drawerkin ?d ?a1 ?a2 ?bq ?aq1 ?aq2 ?t)))
  (:stream plan-press-from
    :inputs (?bq ?aq)
    :domain (and (reached ?bq) (near ?bq stove) (conf arm ?aq) (reached ?aq))
    :outputs (?t)
    :certified (presskin ?bq ?aq ?t))
  ; paper §IV-A: observations (z, X_i, eps) of ?o under its prior ?pb, X_i on surface ?s
  (:stream sample-obs
    :inputs (?o ?pb ?s)
    :domain (possible ?o ?pb ?s)
    :outputs (?obs)
    :certified (and (obs ?o ?obs) (obsof ?pb ?obs) (obson ?obs ?s)))
  ; paper §IV-A: the posterior of ?pb1 assuming ?obs is received (function); it fails unless
  ; the posterior is localized on ?s
  (:stream update-belief
    :inputs (?o ?pb1 ?obs ?s)
    :domain (and (poseb ?o ?pb1) (obs ?o ?obs) (obsof ?pb1 ?obs) (obson ?obs ?s))
    :outputs (?pb2)
    :certified (and (poseb ?o ?pb2) (beliefupdate ?o ?pb1 ?obs ?pb2) (localized ?o ?pb2)
                    (beliefon ?o ?pb2 ?s) (anybase ?o ?pb2)))
  ; paper §IV-A: ?o2 at ?pb2 leaves the region of ?obs visible with probability >= 1 - eps
  (:stream test-vis
    :inputs (?o ?obs ?o2 ?pb2)
    :domain (and (obs ?o ?obs) (poseb ?o2 ?pb2))
    :certified (bvis ?o ?obs ?o2 ?pb2))
  ; the robot at ?bq, arm tucked, leaves the region of ?obs visible
  (:stream test-vis-robot
    :inputs (?o ?obs ?bq)
    :domain (and (obs ?o ?obs) (conf base ?bq))
    :certified (bvisrobot ?o ?obs ?bq))
  ; a placement of ?o at ?pb does not collide with ?o2 under ?pb2 (up to eps)
  (:stream test-cfree
    :inputs (?o ?pb ?o2 ?pb2)
    :domain (and (localized ?o ?pb) (poseb ?o2 ?pb2))
    :certified (cfree ?o ?pb ?o2 ?pb2))
  ; the arm at ?aq, base at ?bq, is clear of ?o2 under ?pb2 (a localized belief, at its
  ; estimate; any other belief is not an obstacle, as for the motion streams)
  (:stream test-afree
    :inputs (?bq ?aq ?o2 ?pb2)
    :domain (and (reach ?bq ?aq) (poseb ?o2 ?pb2))
    :certified (afree ?bq ?aq ?o2 ?pb2))
  ; paper §V: self-loop determinized cost of detect, from the lower bound of eq. 2
  (:function (obscost ?o ?pb ?obs)
    (and (poseb ?o ?pb) (obs ?o ?obs))))
