; Blocks slide on a 2-D table; poses are numpy arrays named in the problem file or sampled.
(define (domain slide2d)
  (:requirements :strips :equality)   ; lax, as files in the wild are: uses :derived, forall
  (:predicates (Block ?b) (Region ?r) (Pose ?b ?p) (AtPose ?b ?p) (Contain ?b ?p ?r)
               (CFree ?b1 ?p1 ?b2 ?p2))
  (:functions (Cost))
  (:derived (In ?b ?r)
    (exists (?p) (and (Contain ?b ?p ?r) (AtPose ?b ?p))))
  (:action slide
    :parameters (?b ?p1 ?p2)
    :precondition (and (Block ?b) (Pose ?b ?p1) (Pose ?b ?p2) (AtPose ?b ?p1)
      ; the new pose is clear of every other block where it is now: CFree used only positively
      (forall (?b2 ?p3) (imply (and (Pose ?b2 ?p3) (AtPose ?b2 ?p3) (not (= ?b ?b2)))
                               (CFree ?b ?p2 ?b2 ?p3))))
    :effect (and (AtPose ?b ?p2) (not (AtPose ?b ?p1)) (increase (total-cost) (Cost))))
)
