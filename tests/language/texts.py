"""Problem-language texts shared by the tests: a lax domain and a stream file as found in the wild.

The domain lists only ``:strips :equality`` but uses derived predicates, exists/forall/imply/or,
negative preconditions and action costs; parameters are untyped and unary predicates act as
types; comments stand everywhere; names mix case. Predicates ``Reach``, ``Base``, ``Path`` and
``Apart`` are never declared: the stream file certifies them.
"""

WILD_DOMAIN = """\
; Pick and place, written for a stream-based planner
(define (domain Pick-And-Place) ; the name mixes case
  (:requirements :strips :equality)  ; incomplete, as usual
  (:predicates
    (Block ?o) (Surface ?s) (Arm ?a)   ; unary predicates used as types
    (CanRest ?o ?s) (Hold ?o ?h)
    (AtPose ?o ?p)                     ; declared as AtPose ...
    (HandEmpty ?a) (Holding ?a ?o ?h) (AtBase ?b)
    (Spot ?o ?p) (Rests ?o ?p ?s)
  )
  (:functions (Cost) (Dist ?q1 ?q2))
  ; a derived predicate quantifying over stream-produced objects
  (:derived (Blocked ?obj ?spot)
    (exists (?o2 ?s2)
      (and (Spot ?o2 ?s2) (atpose ?o2 ?s2) ; ... used as atpose
           (not (= ?o2 ?obj))
           (not (Apart ?obj ?spot ?o2 ?s2)))))
  (:action move_base
    :parameters (?b1 ?b2)
    :precondition (and (Base ?b1) (Base ?b2) (AtBase ?b1)
                       (not (= ?b1 ?b2)))
    :effect (and (AtBase ?b2) (not (AtBase ?b1))
                 (increase (total-cost) (Dist ?b1 ?b2))))
  (:action Pick
    :parameters (?arm ?obj ?spot ?hold ?base ?path)
    :precondition (and (Block ?obj) (Arm ?arm)
                       (Reach ?arm ?obj ?spot ?hold ?base ?path)
                       (ATPOSE ?obj ?spot) (HandEmpty ?arm) (AtBase ?base))
    :effect (and (Holding ?arm ?obj ?hold)
                 (not (AtPose ?obj ?spot)) (not (HandEmpty ?arm))
                 (increase (total-cost) (TravelCost ?path))))
  (:action PLACE
    :parameters (?arm ?obj ?spot ?hold ?base ?path)
    :precondition (and (Reach ?arm ?obj ?spot ?hold ?base ?path)
                       (Holding ; the arm
                                ?arm ?obj ?hold) ; a comment between the parts of an atom
                       (AtBase ?base)
                       (or (Block ?obj) (Surface ?obj))
                       (not (Blocked ?obj ?spot))
                       (forall (?o2 ?s2)
                         (imply (and (Spot ?o2 ?s2) (AtPose ?o2 ?s2))
                                (or (= ?o2 ?obj) (Apart ?obj ?spot ?o2 ?s2)))))
    :effect (and (AtPose ?obj ?spot) (HandEmpty ?arm)
                 (not (Holding ?arm ?obj ?hold))
                 (increase (total-cost) (Cost))))
) ; a comment after the final parenthesis
; and one more line of comment
"""

# The stream file of shared/notes/stream-files.md, with the lines found in the wild added: a
# commented-out ':domain' replaced by the next line, a commented-out ';:fluents' line and an
# active ':fluents (AtPose)' line.
STREAM_FILE = """\
(define (stream my-world)
  (:stream find-spot                    ; a conditional sampler: inputs -> stream of outputs
    :inputs (?obj ?surface)
    ;:domain (and (Block ?obj) (Surface ?surface))
    :domain (CanRest ?obj ?surface)     ; one atom, or (and ...)
    :outputs (?spot)
    :certified (and (Spot ?obj ?spot) (Rests ?obj ?spot ?surface)))
  (:stream reach                        ; several outputs at once
    :inputs (?arm ?obj ?spot ?hold)
    :domain (and (Arm ?arm) (Spot ?obj ?spot) (Hold ?obj ?hold))
    :fluents (AtPose)
    :outputs (?base ?path)
    :certified (and (Base ?base) (Path ?path) (Reach ?arm ?obj ?spot ?hold ?base ?path)))
  (:stream spots-apart                  ; a test: no :outputs
    :inputs (?o1 ?s1 ?o2 ?s2)
    ;:domain (Spot ?o1 ?s1)
    :domain (and (Spot ?o1 ?s1) (Spot ?o2 ?s2))
    ;:fluents (AtPose Holding)
    :certified (Apart ?o1 ?s1 ?o2 ?s2))
  (:function (TravelCost ?path)         ; a numeric function computed in Python
    (Path ?path))
)
"""

WILD_PROBLEM = """\
; a problem file for WILD_DOMAIN
(define (problem Two-Blocks)
  (:domain PICK-AND-PLACE)
  (:objects left a b table s-a s-b s-c h-a base0 base1 path0)
  (:init
    (Arm left) (Block a) (Block b) (Surface table)
    (CanRest a table) (CanRest b table) (Hold a h-a)
    (Spot a s-a) (Spot b s-b) (Spot a s-c) (AtPose a s-a) (AtPose b s-b)
    (HandEmpty left) (AtBase base0)
    (Base base0) (Base base1) (Path path0)           ; stream facts given up front
    (Reach left a s-a h-a base1 path0) (Reach left a s-b h-a base1 path0)
    (Reach left a s-c h-a base1 path0) (Apart a s-c b s-b)
    (= (Cost) 1)
    (= (Dist base0 base1) 3)                          ; numeric init
    (= (TravelCost path0) 2.5))
  (:goal (and (AtPose a s-c) (HandEmpty left)))
  (:metric minimize (total-cost))
)
"""
