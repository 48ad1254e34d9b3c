; Written for llmpas's tests, in the shape of PDDLStream's continuous_tamp/idtmp domain:
; robots carry blocks between regions, and one predicate is declared twice, identically.
(define (domain twice-declared)
  (:requirements :strips :equality)
  (:predicates
    (Robot ?r) (Block ?b) (Region ?s)
    (Holding ?r ?b)
    (HandEmpty ?r) (In ?b ?s) (At ?r ?s)
    (Holding ?r ?b))
  (:action move
    :parameters (?r ?s1 ?s2)
    :precondition (and (Robot ?r) (Region ?s2) (At ?r ?s1))
    :effect (and (At ?r ?s2) (not (At ?r ?s1))))
  (:action pick
    :parameters (?r ?b ?s)
    :precondition (and (Robot ?r) (Block ?b) (At ?r ?s) (In ?b ?s) (HandEmpty ?r))
    :effect (and (Holding ?r ?b) (not (In ?b ?s)) (not (HandEmpty ?r))))
  (:action place
    :parameters (?r ?b ?s)
    :precondition (and (Robot ?r) (Region ?s) (At ?r ?s) (Holding ?r ?b))
    :effect (and (In ?b ?s) (HandEmpty ?r) (not (Holding ?r ?b)))))
