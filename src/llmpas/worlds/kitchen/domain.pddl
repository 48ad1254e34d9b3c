; A household: a mobile manipulator picks and places objects between tables, drawers, appliances,
; a bowl and (in some houses) the floor, looks on tables, into open containers and under covers,
; and cleans, cooks, heats, cools and dries food.
; Capacities: Single regions hold one object, Double regions two (Full says so, count-free).
; Doors: a Jammed container does not open; one is Obstructed while an object stands at a pose
; that Blocks it (in front of its door): pick that object and put it elsewhere first.
; Object states: Cooked food is not cooked again; Hot food does not go into the fridge (rinsing
; it in the sink cools it); Spilled food is rinsed before it is heated; Wet things are dried on a
; table before they go into a drawer; Broken things are not picked up.
; Geometry (base poses, reachability, base motions) comes from streams; Kin, BaseMotion and View
; are deferred to execution by default.
(define (domain household)
  (:requirements :strips :equality)     ; lax, as wild files are: derived predicates, costs
  (:predicates
    (Object ?o) (Region ?r) (Surface ?r) (Drawer ?r) (Openable ?r) (Cover ?c)
    (Sink ?r) (Stove ?r) (Microwave ?r) (Fridge ?r)
    (Single ?r) (Double ?r)             ; room for one object, for two
    (Jammed ?r) (Blocks ?p ?r)          ; a door that does not open; a pose in front of door ?r
    (Searched ?r)                       ; a closed container (not a drawer) to look into
    (Stackable ?o ?r)
    (Pose ?o ?p) (Supported ?o ?p ?r) (AtPose ?o ?p)
    (Grasp ?o ?g) (AtGrasp ?o ?g) (HandEmpty)
    (BConf ?q) (AtBConf ?q) (CanMove)
    (Kin ?o ?p ?g ?q)                   ; from base ?q the arm reaches ?o at ?p with grasp ?g
    (BaseMotion ?q1 ?t ?q2)             ; a collision-free drive
    (View ?r ?q)                        ; from base ?q the robot sees (and reaches) region ?r
    (CFree ?o ?p ?o2 ?p2)               ; footprints do not overlap
    (Open ?r)
    (Dirty ?o) (Cleaned ?o) (Cooked ?o) (Heated ?o) (Cooled ?o)
    (Hot ?o) (Wet ?o) (Broken ?o) (Spilled ?o)
    (Scanned ?r))
  (:functions (Distance ?q1 ?q2))

  (:derived (On ?o ?r) (exists (?p) (and (Supported ?o ?p ?r) (AtPose ?o ?p))))
  (:derived (Holding ?o) (exists (?g) (and (Grasp ?o ?g) (AtGrasp ?o ?g))))
  (:derived (Accessible ?r) (and (Region ?r) (or (not (Openable ?r)) (Open ?r))))
  (:derived (Full ?r)
    (or (exists (?o) (and (Single ?r) (On ?o ?r)))
        (exists (?o ?o2) (and (Double ?r) (On ?o ?r) (On ?o2 ?r) (not (= ?o ?o2))))))
  (:derived (Obstructed ?r) (exists (?o ?p) (and (Blocks ?p ?r) (AtPose ?o ?p))))
  (:derived (Soaks ?o ?r) (and (Drawer ?r) (Wet ?o)))   ; a wet thing would soak the drawer
  (:derived (UnsafePose ?o ?p)
    (exists (?o2 ?p2) (and (Pose ?o ?p) (Pose ?o2 ?p2) (AtPose ?o2 ?p2) (not (= ?o ?o2))
                           (not (CFree ?o ?p ?o2 ?p2)))))

  (:action move_base
    :parameters (?q1 ?q2 ?t)
    :precondition (and (BaseMotion ?q1 ?t ?q2) (AtBConf ?q1) (CanMove))
    :effect (and (AtBConf ?q2) (not (AtBConf ?q1)) (not (CanMove))
                 (increase (total-cost) (Distance ?q1 ?q2))))

  (:action pick
    :parameters (?o ?p ?r ?g ?q)
    :precondition (and (Kin ?o ?p ?g ?q) (Supported ?o ?p ?r) (AtPose ?o ?p) (HandEmpty)
                       (AtBConf ?q) (Accessible ?r) (not (Broken ?o)))
    :effect (and (AtGrasp ?o ?g) (CanMove) (not (AtPose ?o ?p)) (not (HandEmpty))
                 (increase (total-cost) 1)))

  (:action place
    :parameters (?o ?p ?r ?g ?q)
    :precondition (and (Kin ?o ?p ?g ?q) (Supported ?o ?p ?r) (AtGrasp ?o ?g) (AtBConf ?q)
                       (Accessible ?r) (not (Full ?r)) (not (Soaks ?o ?r))
                       (not (UnsafePose ?o ?p)))
    :effect (and (AtPose ?o ?p) (HandEmpty) (CanMove) (not (AtGrasp ?o ?g))
                 (increase (total-cost) 1)))

  (:action scan_table
    :parameters (?r ?q)
    :precondition (and (Surface ?r) (View ?r ?q) (AtBConf ?q))
    :effect (and (Scanned ?r) (CanMove) (increase (total-cost) 1)))

  (:action scan_drawer
    :parameters (?r ?q)
    :precondition (and (Drawer ?r) (Open ?r) (View ?r ?q) (AtBConf ?q))
    :effect (and (Scanned ?r) (CanMove) (increase (total-cost) 1)))

  (:action scan_container                ; look into the open fridge or microwave
    :parameters (?r ?q)                 ; (Searched ?r): a container a goal asks to search
    :precondition (and (Searched ?r) (Open ?r) (View ?r ?q) (AtBConf ?q))
    :effect (and (Scanned ?r) (CanMove) (increase (total-cost) 1)))

  (:action scan_cover                   ; lift the cover, look under it, put it back
    :parameters (?c ?p ?r ?g ?q)
    :precondition (and (Cover ?c) (Kin ?c ?p ?g ?q) (Supported ?c ?p ?r) (AtPose ?c ?p)
                       (HandEmpty) (AtBConf ?q))
    :effect (and (Scanned ?c) (CanMove) (increase (total-cost) 1)))

  (:action open
    :parameters (?r ?q)
    :precondition (and (Openable ?r) (View ?r ?q) (AtBConf ?q) (HandEmpty) (not (Open ?r))
                       (not (Jammed ?r)) (not (Obstructed ?r)))
    :effect (and (Open ?r) (CanMove) (increase (total-cost) 1)))

  (:action close
    :parameters (?r ?q)
    :precondition (and (Openable ?r) (View ?r ?q) (AtBConf ?q) (HandEmpty) (Open ?r))
    :effect (and (not (Open ?r)) (CanMove) (increase (total-cost) 1)))

  (:action clean
    :parameters (?o ?r)
    :precondition (and (Sink ?r) (On ?o ?r))
    :effect (and (Cleaned ?o) (not (Dirty ?o)) (not (Hot ?o)) (not (Spilled ?o))
                 (increase (total-cost) 1)))

  (:action cook
    :parameters (?o ?r)
    :precondition (and (Stove ?r) (On ?o ?r) (not (Dirty ?o)) (not (Cooked ?o)))
    :effect (and (Cooked ?o) (increase (total-cost) 1)))

  (:action heat
    :parameters (?o ?r)
    :precondition (and (Microwave ?r) (On ?o ?r) (not (Open ?r)) (not (Spilled ?o)))
    :effect (and (Heated ?o) (increase (total-cost) 1)))

  (:action cool
    :parameters (?o ?r)
    :precondition (and (Fridge ?r) (On ?o ?r) (not (Open ?r)) (not (Dirty ?o)) (not (Hot ?o)))
    :effect (and (Cooled ?o) (increase (total-cost) 1)))

  (:action dry                          ; wipe a wet object dry on a table
    :parameters (?o ?r)
    :precondition (and (Surface ?r) (On ?o ?r) (Wet ?o))
    :effect (and (not (Wet ?o)) (increase (total-cost) 1)))
)
