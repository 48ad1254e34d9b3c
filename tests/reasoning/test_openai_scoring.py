"""Scores from an OpenAI-compatible server (issue #36, item 5): each choice is asked for with a
grammar that fixes the answer to it and ``logprobs``; the answer's token log-probabilities are
the choice's score (the prefix's tokens left out). A server that ignores the grammar, sends no
log-probabilities or refuses the request cannot score (the chooser falls back to a numbered
choice, and the server is not asked to score again); a malformed answer is one line naming the
server. Against scripted servers on 127.0.0.1 (tests/llm_server.py); the real one is
tests/reasoning/test_server_scoring.py."""

from __future__ import annotations

import json
import math

import pytest

from llmpas.reasoning.backends import OpenAIBackend
from llmpas.reasoning.llm import LLMServerError, Message, ScoreRequest, ScoringUnsupported
from tests.llm_server import Reply, completion_body, serve

PREFIX = "Goals: "
REQUEST = ScoreRequest(
    (Message("system", "You plan."), Message("user", "The bread is frozen.")),
    ("(and (heated bread))", "(and (cleaned bread))"),
    PREFIX,
)


def scored_body(tokens: list[tuple[str, float]], content: str | None = None) -> bytes:
    """A chat completion whose answer is the tokens, with their log-probabilities."""
    text = "".join(t for t, _ in tokens) if content is None else content
    data = json.loads(completion_body(text))
    data["choices"][0]["logprobs"] = {
        "content": [
            {"token": t, "logprob": lp, "bytes": None, "top_logprobs": []} for t, lp in tokens
        ]
    }
    return json.dumps(data).encode()


HEATED = [("Goals", -0.5), (":", -0.1), (" (", -0.2), ("and", -0.3), (" (", -0.4)]
HEATED += [("heated", -1.0), (" bread", -0.5), ("))", -0.1)]
CLEANED = [("Goals", -0.5), (":", -0.1), (" (", -0.2), ("and", -0.3), (" (", -0.4)]
CLEANED += [("cleaned", -3.0), (" bread", -0.5), ("))", -0.1)]


def backend(url: str) -> OpenAIBackend:
    return OpenAIBackend("tiny", base_url=url, timeout=5, max_retries=0)


def test_each_choice_is_forced_by_a_grammar_and_scored_by_its_own_tokens() -> None:
    with serve(Reply(200, scored_body(HEATED)), Reply(200, scored_body(CLEANED))) as srv:
        scores = backend(srv.url).score(REQUEST)
    # the prefix's tokens ("Goals", ":") are left out; " (" crosses into the choice: kept
    assert scores.logprobs == ((-0.2, -0.3, -0.4, -1.0, -0.5, -0.1),) * 1 + (
        (-0.2, -0.3, -0.4, -3.0, -0.5, -0.1),
    )
    assert scores.mean()[0] > scores.mean()[1]
    first, second = srv.received
    assert first["logprobs"] is True and first["temperature"] == 0.0
    assert first["grammar"] == 'root ::= "Goals: (and (heated bread))"\n'
    assert second["grammar"] == 'root ::= "Goals: (and (cleaned bread))"\n'
    assert first["messages"][-1] == {"role": "user", "content": "The bread is frozen."}
    assert first["max_tokens"] >= len("Goals: (and (heated bread))")


def test_a_choice_with_quotes_is_escaped_in_the_grammar() -> None:
    odd = ScoreRequest(REQUEST.messages, ('say "hi" \\ now',), "")
    tokens = [('say "hi" \\ now', -1.5)]
    with serve(Reply(200, scored_body(tokens))) as srv:
        scores = backend(srv.url).score(odd)
    assert scores.logprobs == ((-1.5,),)
    assert srv.received[0]["grammar"] == 'root ::= "say \\"hi\\" \\\\ now"\n'


@pytest.mark.parametrize(
    "reply",
    [
        Reply(200, completion_body("Goals: (and (heated bread))")),  # no logprobs
        Reply(200, scored_body(HEATED, content="Goals: (and (on bread plate))")),  # grammar ignored
        Reply(400, b'{"error": {"message": "unknown parameter grammar"}}'),  # refused
        Reply(200, scored_body([("Goals: (and (heated", -1.0)])),  # tokens short of the choice
    ],
    ids=["no-logprobs", "grammar-ignored", "refused", "tokens-short"],
)
def test_a_server_that_cannot_score_says_so_once(reply: Reply) -> None:
    with serve(reply) as srv:
        llm = backend(srv.url)
        with pytest.raises(ScoringUnsupported, match=r"127\.0\.0\.1:\d+"):
            llm.score(REQUEST)
        asked = len(srv.received)
        with pytest.raises(ScoringUnsupported):
            llm.score(REQUEST)
        assert len(srv.received) == asked == 1  # not asked to score again


@pytest.mark.parametrize(
    "tokens",
    [
        [("Goals: (and (heated bread))", math.nan)],
        [("Goals: (and (heated bread))", 5.0)],
        [("Goals: (and (heated bread))", "high")],
        [("Goals: (and (heated bread))", True)],
    ],
    ids=["nan", "positive", "string", "bool"],
)
def test_malformed_log_probabilities_are_one_line_naming_the_server(tokens: list) -> None:
    body = scored_body(tokens)  # json.dumps writes NaN as the JSON extension Python reads
    with serve(Reply(200, body)) as srv, pytest.raises(LLMServerError) as err:
        backend(srv.url).score(REQUEST)
    text = str(err.value)
    assert "\n" not in text and "127.0.0.1" in text and "logprob" in text


def test_a_server_error_while_scoring_is_an_llm_error_not_unsupported() -> None:
    with serve(Reply(500, b'{"error": "boom"}')) as srv, pytest.raises(LLMServerError) as err:
        backend(srv.url).score(REQUEST)
    assert not isinstance(err.value, ScoringUnsupported) and "HTTP 500" in str(err.value)


def test_scoring_many_choices_is_bounded_as_a_whole() -> None:
    """Each answer comes just in time, but the choices together may take at most four request
    timeouts: then one line, not minutes per candidate."""
    many = ScoreRequest(REQUEST.messages, ("(and (heated bread))",) * 40, PREFIX)
    slow = Reply(200, scored_body(HEATED), delay=0.3)
    with serve(slow) as srv, pytest.raises(LLMServerError, match="took over 4 s") as err:
        OpenAIBackend("tiny", base_url=srv.url, timeout=1.0, max_retries=0).score(many)
    assert "\n" not in str(err.value) and len(srv.received) < 40


def test_with_a_tokenizer_endpoint_the_model_s_own_tokens_are_forced() -> None:
    """``llama_cpp.server`` tokenizes (``/extras/tokenize``): the grammar forces those tokens
    one by one (the sampler could pick another segmentation of the same text), and the
    prefix's tokens are left out by count."""
    import threading
    from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

    vocab = {"": [], "Goals: ": [7, 8], "Goals: (and (heated bread))": [7, 9, 10, 11]}
    asked: list[dict] = []

    class Handler(BaseHTTPRequestHandler):
        def do_POST(self) -> None:
            body = json.loads(self.rfile.read(int(self.headers["Content-Length"])))
            asked.append({"path": self.path, **body})
            if self.path == "/extras/tokenize":
                data = json.dumps({"tokens": vocab[body["input"]]}).encode()
            else:
                tokens = [("Goals:", -0.1), (" (", -0.2), ("and (heated", -0.3), (" bread))", -0.4)]
                data = scored_body(tokens)
            self.send_response(200)
            self.send_header("Content-Length", str(len(data)))
            self.end_headers()
            self.wfile.write(data)

        def log_message(self, *args: object) -> None:
            pass

    httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    threading.Thread(target=httpd.serve_forever, daemon=True).start()
    try:
        url = f"http://127.0.0.1:{httpd.server_address[1]}/v1"
        one = ScoreRequest(REQUEST.messages, ("(and (heated bread))",), PREFIX)
        scores = backend(url).score(one)
    finally:
        httpd.shutdown()
        httpd.server_close()
    assert scores.logprobs == ((-0.2, -0.3, -0.4),)  # after the one token the prefix shares
    chat = next(a for a in asked if a["path"] == "/v1/chat/completions")
    assert chat["grammar"] == "root ::= <[7]> <[9]> <[10]> <[11]>\n"
    assert chat["max_tokens"] == 5
