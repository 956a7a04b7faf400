; Streams of the 2-D pick-and-place domain (paper §IV), implemented in streams/tamp2d.py.
(define (stream tamp2d)
  ; generator, endless and lazy: poses of ?b inside region ?r (may overlap other blocks)
  (:stream sample-placement
    :inputs (?b ?r)
    :domain (and (Block ?b) (Region ?r))
    :outputs (?p)
    :certified (and (Pose ?b ?p) (Contained ?b ?p ?r)))
  ; generator, finite: vertical grasp offsets; its first draw fails (yields nothing)
  (:stream sample-grasp
    :inputs (?b)
    :domain (Block ?b)
    :outputs (?g)
    :certified (Grasp ?b ?g))
  ; function: the gripper configuration holding ?b at ?p with ?g (none when out of reach)
  (:stream ik
    :inputs (?b ?p ?g)
    :domain (and (Pose ?b ?p) (Grasp ?b ?g))
    :outputs (?q)
    :certified (and (Conf ?q) (Kin ?b ?p ?g ?q)))
  ; deferrable: a trajectory up, across and down between two configurations
  (:stream motion
    :inputs (?q1 ?q2)
    :domain (and (Conf ?q1) (Conf ?q2))
    :outputs (?t)
    :certified (and (Traj ?t) (Motion ?q1 ?t ?q2)))
  ; test: the two blocks' intervals on the table do not overlap
  (:stream test-cfree
    :inputs (?b ?p ?b2 ?p2)
    :domain (and (Pose ?b ?p) (Pose ?b2 ?p2))
    :certified (CFree ?b ?p ?b2 ?p2))
  ; cost function: length of the motion between two configurations
  (:function (Distance ?q1 ?q2)
    (and (Conf ?q1) (Conf ?q2))))
