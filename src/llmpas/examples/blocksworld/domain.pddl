; Classic four-operator blocks world (untyped, as most files in the wild are).
(define (domain blocksworld)
  (:requirements :strips)          ; nothing more is needed
  (:predicates
    (on ?x ?y)                     ; ?x sits directly on ?y
    (ontable ?x)
    (clear ?x)                     ; nothing on ?x
    (handempty)
    (holding ?x))

  (:action pickup                  ; from the table
    :parameters (?x)
    :precondition (and (clear ?x) (ontable ?x) (handempty))
    :effect (and (holding ?x)
                 (not (ontable ?x)) (not (clear ?x)) (not (handempty))))

  (:action putdown                 ; onto the table
    :parameters (?x)
    :precondition (holding ?x)
    :effect (and (ontable ?x) (clear ?x) (handempty)
                 (not (holding ?x))))

  (:action stack
    :parameters (?x ?y)
    :precondition (and (holding ?x) (clear ?y))
    :effect (and (on ?x ?y) (clear ?x) (handempty)
                 (not (holding ?x)) (not (clear ?y))))

  (:action unstack
    :parameters (?x ?y)
    :precondition (and (on ?x ?y) (clear ?x) (handempty))
    :effect (and (holding ?x) (clear ?y)
                 (not (on ?x ?y)) (not (clear ?x)) (not (handempty))))
) ; end of domain
