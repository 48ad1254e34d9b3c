; A stack of blocks: a grasp of a block exists only while no block is on it (a fluent stream).
(define (domain stack)
  (:requirements :strips :equality)
  (:constants table)
  (:predicates (Block ?b) (On ?b ?s) (Holding ?b) (HandEmpty) (Grasp ?b ?g))
  (:action pick
    :parameters (?b ?s ?g)
    :precondition (and (Grasp ?b ?g) (On ?b ?s) (HandEmpty))
    :effect (and (Holding ?b) (not (On ?b ?s)) (not (HandEmpty))))
  (:action put
    :parameters (?b)
    :precondition (Holding ?b)
    :effect (and (On ?b table) (HandEmpty) (not (Holding ?b)))))
