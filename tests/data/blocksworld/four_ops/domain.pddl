;; A four-operator blocks world spelled the other common way (hyphenated names, an "arm"),
;; written for llmpas's tests: the bench must read any naming of the same domain.
(define (domain blocks-4op-variant)
  (:requirements :strips)
  (:predicates (holding ?b) (arm-empty) (on-table ?b) (on ?top ?below) (clear ?b))

  (:action unstack
    :parameters (?top ?below)
    :precondition (and (arm-empty) (clear ?top) (on ?top ?below))
    :effect (and (not (arm-empty)) (not (clear ?top)) (not (on ?top ?below))
                 (holding ?top) (clear ?below)))

  (:action put-down
    :parameters (?b)
    :precondition (holding ?b)
    :effect (and (not (holding ?b)) (arm-empty) (clear ?b) (on-table ?b)))

  (:action pick-up
    :parameters (?b)
    :precondition (and (on-table ?b) (arm-empty) (clear ?b))
    :effect (and (holding ?b) (not (arm-empty)) (not (on-table ?b)) (not (clear ?b))))

  (:action stack
    :parameters (?top ?below)
    :precondition (and (clear ?below) (holding ?top))
    :effect (and (on ?top ?below) (not (clear ?below)) (not (holding ?top))
                 (arm-empty) (clear ?top))))
