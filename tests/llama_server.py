"""``python -m tests.llama_server ARGS``: ``python -m llama_cpp.server ARGS`` with the model built
as llmpas's worker builds it, with llama.cpp's extra buffer types off
(:func:`llmpas.reasoning.backends.llamacpp_worker._model_params`): with them, llama.cpp's AMX
matrix multiply crashes on CPUs with AMX (docs/native-crashes.md; the server segfaulted on its
first completion on such a machine)."""

from __future__ import annotations

import runpy
import sys


def main() -> None:
    import llama_cpp

    from llmpas.reasoning.backends.llamacpp_worker import _model_params

    sys.argv = ["llama_cpp.server", *sys.argv[1:]]
    with _model_params(llama_cpp, False):
        runpy.run_module("llama_cpp.server", run_name="__main__", alter_sys=True)


if __name__ == "__main__":
    main()
