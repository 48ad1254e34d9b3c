"""Stream declarations: files as written for PDDLStream read unchanged, and their errors."""

from __future__ import annotations

import pytest

from llmpas.language.language_errors import ModelError, PddlSyntaxError
from llmpas.language.logic import Atom
from llmpas.language.streams import (
    EMPTY_STREAMS,
    FunctionSchema,
    StreamSchema,
    StreamSpec,
    parse_streams,
    read_streams,
)

from .texts import STREAM_FILE


def where(text: str, needle: str) -> tuple[int, int]:
    offset = text.index(needle)
    before = text[:offset]
    return before.count("\n") + 1, offset - before.rfind("\n")


def stream_error(text: str) -> PddlSyntaxError:
    with pytest.raises(PddlSyntaxError) as info:
        parse_streams(text, "s.pddl")
    assert "\n" not in str(info.value)
    assert str(info.value).startswith(f"s.pddl:{info.value.line}:{info.value.col}: ")
    return info.value


def one_stream(body: str) -> str:
    return f"(define (stream s)\n  (:stream gen\n    {body}))"


# ------------------------------------------------------------------------ the file of the note


def test_stream_file_of_the_note_reads_unchanged(wild_streams):
    spec = wild_streams
    assert spec.name == "my-world"
    assert spec.filename == "wild/stream.pddl"
    assert [s.name for s in spec.streams] == ["find-spot", "reach", "spots-apart"]

    find = spec.stream("find-spot")
    assert find.inputs == ("?obj", "?surface")
    # the commented-out ':domain' line is ignored; the line after it counts
    assert find.domain == (Atom("canrest", ("?obj", "?surface")),)
    assert find.outputs == ("?spot",)
    assert find.certified == (
        Atom("spot", ("?obj", "?spot")),
        Atom("rests", ("?obj", "?spot", "?surface")),
    )
    assert find.fluents == ()
    assert not find.is_test

    reach = spec.stream("reach")
    assert reach.outputs == ("?base", "?path")  # several outputs at once
    assert reach.domain == (
        Atom("arm", ("?arm",)),
        Atom("spot", ("?obj", "?spot")),
        Atom("hold", ("?obj", "?hold")),
    )
    assert reach.fluents == ("atpose",)  # the active ':fluents' line, lower-cased
    assert Atom("reach", ("?arm", "?obj", "?spot", "?hold", "?base", "?path")) in reach.certified

    apart = spec.stream("spots-apart")
    assert apart.is_test
    assert apart.outputs == ()
    assert apart.fluents == ()  # ';:fluents (AtPose Holding)' is a comment
    assert apart.domain == (Atom("spot", ("?o1", "?s1")), Atom("spot", ("?o2", "?s2")))
    assert apart.certified == (Atom("apart", ("?o1", "?s1", "?o2", "?s2")),)

    (fn,) = spec.functions
    assert fn == FunctionSchema(Atom("travelcost", ("?path",)), (Atom("path", ("?path",)),))
    assert fn.name == "travelcost"


def test_certified_predicates(wild_streams):
    assert wild_streams.certified_predicates == {
        "spot": 2,
        "rests": 3,
        "base": 1,
        "path": 1,
        "reach": 6,
        "apart": 4,
    }


def test_read_streams_from_file(tmp_path):
    path = tmp_path / "stream.pddl"
    path.write_text(STREAM_FILE, encoding="utf-8")
    spec = read_streams(path)
    assert spec.filename == str(path)
    assert spec.streams == parse_streams(STREAM_FILE).streams


def test_unknown_stream_lookup(wild_streams):
    with pytest.raises(ModelError, match=r"^wild/stream\.pddl: unknown stream 'nope'$"):
        wild_streams.stream("nope")


def test_empty_spec():
    assert EMPTY_STREAMS.streams == ()
    assert EMPTY_STREAMS.functions == ()
    assert EMPTY_STREAMS.certified_predicates == {}


def test_stream_without_inputs_and_single_atom_certified():
    spec = parse_streams(
        "(define (stream s) (:stream sample-conf :outputs (?q) :certified (Conf ?q)))"
    )
    (s,) = spec.streams
    assert s.inputs == () and s.domain == ()
    assert s.certified == (Atom("conf", ("?q",)),)


def test_empty_domain_and_nested_and():
    spec = parse_streams(
        "(define (stream s) (:stream g :inputs () :domain () :outputs (?q) "
        ":certified (and (A ?q) (and (B ?q) (C ?q)))))"
    )
    (s,) = spec.streams
    assert s.domain == ()
    assert [a.predicate for a in s.certified] == ["a", "b", "c"]


def test_constants_may_appear_in_domain_and_certified():
    spec = parse_streams(
        "(define (stream s) (:stream g :inputs (?x) :domain (On ?x Table) :outputs (?y) "
        ":certified (Near ?y Table)))"
    )
    assert spec.streams[0].domain == (Atom("on", ("?x", "table")),)


def test_function_without_domain():
    spec = parse_streams("(define (stream s) (:function (Cost)))")
    assert spec.functions == (FunctionSchema(Atom("cost"), ()),)


# ------------------------------------------------------------------------ bad input


def test_input_not_in_domain():
    text = one_stream(
        ":inputs (?x ?w)\n    :domain (P ?x)\n    :outputs (?y)\n    :certified (Q ?x ?y)"
    )
    err = stream_error(text)
    assert (err.line, err.col) == where(text, "(:stream")
    assert err.message == "stream 'gen': input ?w does not occur in :domain"


def test_outputs_given_twice():
    text = one_stream(
        ":inputs (?x) :domain (P ?x)\n    :outputs (?y)\n"
        "    :outputs (?z)\n    :certified (Q ?x ?y)"
    )
    err = stream_error(text)
    assert (err.line, err.col) == where(text, ":outputs (?z)")
    assert err.message == "':outputs' given twice in stream 'gen'"


@pytest.mark.parametrize(
    ("body", "message"),
    [
        (
            ":inputs (?x) :domain (P ?x ?z) :outputs (?y) :certified (Q ?y)",
            "stream 'gen': :domain uses ?z, not an input",
        ),
        (
            ":inputs (?x) :domain (P ?x) :outputs (?y) :certified (Q ?x ?z)",
            "stream 'gen': :certified uses unknown variable ?z",
        ),
        (
            ":inputs (?x) :domain (P ?x) :outputs (?x) :certified (Q ?x)",
            "stream 'gen': a variable is both input and output, or twice",
        ),
        (":inputs (?x) :domain (P ?x) :output (?y)", "unknown keyword ':output' in stream 'gen'"),
        (":inputs (x) :domain (P x)", "expected a '?variable' in :inputs, found 'x'"),
        (
            ":inputs (?x) :domain (not (P ?x))",
            ":domain must be a conjunction of atoms, found 'not'",
        ),
        (
            ":inputs (?x) :domain (P ?x) :certified (or (Q ?x) (R ?x))",
            ":certified must be a conjunction of atoms, found 'or'",
        ),
        (":inputs (?x) :domain (P ?x) :outputs (?y) (?z)", "':outputs' takes exactly one value"),
        ("(?x)", "expected a ':keyword' in stream 'gen'"),
    ],
)
def test_malformed_streams(body, message):
    err = stream_error(one_stream(body))
    assert err.message == message or err.message.startswith(message)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("(define (domain s))", "expected '(stream NAME)'"),
        ("(stream s)", "expected '(define (stream NAME) ...)'"),
        (
            "(define (stream s) (:predicate p :inputs (?x) :domain (P ?x)))",
            "expected '(:predicate (NAME ?x ...) DOMAIN)'",
        ),
        ("(define (stream s) (:predicate (P a) (Q a)))", "expected a '?variable' in"),
        ("(define (stream s) (:predicate (P ?x ?y) (Q ?x)))", "stream 'p': input ?y does not"),
        ("(define (stream s) (:rule (p)))", "expected a ':keyword' in ':rule' (rule-1)"),
        (
            "(define (stream s) (:rule :inputs (?x) :domain (P ?x) :outputs (?y)))",
            "unknown keyword ':outputs' in ':rule' (rule-1)",
        ),
        ("(define (stream s) (:objective (p)))", "expected ':stream', ':function', ':predicate'"),
        ("(define (stream s) (:function (F ?x ?y) (P ?x)))", "function 'f': ?y does not occur"),
        ("(define (stream s) (:function (F) (P) (Q)))", "expected '(:function (NAME ?x ...)"),
        ("(define (stream s) (:stream))", "expected '(:stream NAME :inputs ... )'"),
    ],
)
def test_malformed_stream_files(text, message):
    err = stream_error(text)
    assert err.message.startswith(message)


def test_stream_declared_twice_is_an_error():
    text = (
        "(define (stream s)\n"
        "  (:stream a :inputs (?x) :domain (P ?x) :outputs (?y) :certified (Q ?x ?y))\n"
        "  (:stream A :inputs (?x) :domain (P ?x) :outputs (?z) :certified (Q ?x ?z)))"
    )
    err = stream_error(text)
    assert err.message == "stream 'a' is declared twice"


def test_stream_and_function_share_one_namespace():
    err = stream_error(
        "(define (stream s) (:stream f :outputs (?y) :certified (Q ?y)) (:function (F)))"
    )
    assert err.message == "stream 'f' is declared twice"


def test_schema_checks_in_python():
    with pytest.raises(ModelError, match="input \\?b does not occur in :domain"):
        StreamSchema("s", ("?a", "?b"), (Atom("p", ("?a",)),), (), ())
    with pytest.raises(ModelError, match="declared twice"):
        s = StreamSchema("s", (), (), ("?y",), (Atom("q", ("?y",)),))
        StreamSpec("x", (s, s))


# ------------------------------------------------------------- :predicate, :rule, unsupported

KINDS = """(define (stream kinds)
  (:rule :inputs (?q ?p) :domain (Kin ?q ?p) :certified (and (Conf ?q) (Pose ?p)))
  (:rule :parameters (?q) :domain (Conf ?q) :certified (Config ?q))  ; :parameters: same
  (:rule :inputs (?a ?b) :domain (and (Pose ?a) (Pose ?b)) :certified (Pair ?a ?b))
  (:stream ik :inputs (?p) :domain (Pose ?p) :outputs (?q) :certified (Kin ?q ?p))
  (:predicate (Collide ?p1 ?p2) (and (Pose ?p1) (Pose ?p2)))
  ;(:predicate (Commented ?p) (Pose ?p))
)"""


def test_external_predicate_is_a_test_of_its_complement():
    spec = parse_streams(KINDS, "k.pddl")
    collide = spec.stream("collide")
    assert collide.is_predicate and collide.is_test and not collide.is_rule
    assert collide.inputs == ("?p1", "?p2")
    assert collide.domain == (Atom("pose", ("?p1",)), Atom("pose", ("?p2",)))
    assert collide.certified == (Atom("not__collide", ("?p1", "?p2")),)
    assert spec.external_predicates == {"collide": "not__collide"}
    assert "not__collide" in spec.test_predicates


def test_rules_are_named_tests_and_single_atom_rules_fold_into_streams():
    spec = parse_streams(KINDS, "k.pddl")
    rules = [s for s in spec.streams if s.is_rule]
    assert [r.name for r in rules] == ["rule-1", "rule-2", "rule-3"]
    assert rules[1].inputs == ("?q",)  # ':parameters' read as ':inputs'
    assert all(r.is_test for r in rules)
    # rules never fail: their predicates get no rejections
    assert spec.test_predicates == {"not__collide"}
    # Kin -> Conf, Pose (rule 1), then Conf -> Config (rule 2, through rule 1); rule 3 has two
    # domain atoms and is not folded
    assert spec.stream("ik").certified == (
        Atom("kin", ("?q", "?p")),
        Atom("conf", ("?q",)),
        Atom("pose", ("?p",)),
        Atom("config", ("?q",)),
    )
    assert rules[0].certified == (Atom("conf", ("?q",)), Atom("pose", ("?p",)))


def test_rule_folding_respects_constants_and_repeated_variables():
    text = """(define (stream s)
      (:rule :inputs (?x) :domain (Link ?x ?x) :certified (Loop ?x))
      (:rule :inputs (?x) :domain (Link home ?x) :certified (FromHome ?x))
      (:stream a :inputs (?p) :domain (P ?p) :outputs (?y) :certified (Link ?p ?y))
      (:stream b :inputs (?p) :domain (P ?p) :outputs (?y) :certified (Link ?y ?y)))"""
    spec = parse_streams(text)
    assert spec.stream("a").certified == (Atom("link", ("?p", "?y")),)
    assert spec.stream("b").certified == (Atom("link", ("?y", "?y")), Atom("loop", ("?y",)))


@pytest.mark.parametrize(
    ("text", "needle", "message"),
    [
        (
            "(define (stream s)\n  (:optimizer gurobi\n    (:variables (?p) :inputs ())))",
            "(:optimizer",
            "':optimizer' is not supported",
        ),
    ],
)
def test_unsupported_stream_constructs_get_one_line_at_their_place(text, needle, message):
    err = stream_error(text)
    assert (err.line, err.col) == where(text, needle)
    assert message in err.message
