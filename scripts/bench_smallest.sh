#!/usr/bin/env bash
# Every `llmpas bench` subcommand at its smallest setting, each into OUT/NAME (its console output
# in OUT/NAME.log, its exit status in OUT/NAME.rc), and every subcommand's --help in
# OUT/help/NAME.txt: run it before and after a change and compare the two folders
# (scripts/bench_compare.py). Usage: scripts/bench_smallest.sh OUT [NAME...]
# `bench all` is left out (its steps are these subcommands; it takes many minutes).
set -u
out=$(realpath -m "${1:?usage: bench_smallest.sh OUT [NAME...]}")
shift
here=$(cd "$(dirname "$0")/.." && pwd)
export PYTHONPATH="$here/src${PYTHONPATH:+:$PYTHONPATH}" COLUMNS=120 PYTHONHASHSEED=0
llmpas() { python -c 'import sys; from llmpas.cli import main; sys.exit(main())' "$@"; }
names=("$@")
[ ${#names[@]} -gt 0 ] || names=(validate-data planning-time tamp pddlstream perturbation \
    prompting recovery knowledge blocksworld llm report ros live)
mkdir -p "$out/help"
cd "$out"
llmpas bench --help >"help/bench.txt" 2>&1
llmpas bench all --help >"help/all.txt" 2>&1
for name in "${names[@]}"; do
    llmpas bench "$name" --help >"help/$name.txt" 2>&1
    o="$out/$name"
    rm -rf "$o" && mkdir -p "$o"
    case $name in
    validate-data)
        mkdir -p "$o/suite" && cp "$here/src/llmpas/experiments/suite/household/ol02-table1.toml" "$o/suite/"
        args=("$o/suite" --seeds 1) ;;
    planning-time) args=(--examples tamp2d --sizes 2 --trials 1 --out "$o") ;;
    tamp) args=(--families mirror --sizes 1 --trials 1 --out "$o") ;;
    pddlstream) args=("$here/tests/pddlstream/scripts" --instance tamp2d.py --seeds 1 --out "$o") ;;
    perturbation) args=(--episodes 1 --out "$o") ;;
    prompting) args=(--llm oracle --methods flp --tasks ol02-table1 --samples 1 --out "$o") ;;
    recovery) args=(--tasks ab06-sink-mug --no-oracle --no-replan --methods candidates-first --out "$o") ;;
    knowledge) args=(--llm llama-cpp --methods flp-choose --tasks ol02-table1 --out "$o") ;;
    blocksworld) args=(--llm oracle --count 1 --sizes 3 --out "$o") ;;
    llm) args=(--cassettes "$here/tests/data/cassettes/qwen1.5b" --consultations 1 --busy 0 --scores 0 --out "$o") ;;
    report) args=(--repeats 1) ;;
    ros) args=(--repeats 1 --json "$o/ros.json") ;;
    live) args=(--repeats 1 --json "$o/live.json") ;;
    *) echo "unknown benchmark $name" >&2; continue ;;
    esac
    mkdir -p "$o"
    echo "== llmpas bench $name ${args[*]}" >&2
    llmpas bench "$name" "${args[@]}" >"$out/$name.log" 2>&1
    echo $? >"$out/$name.rc"
    echo "   exit $(cat "$out/$name.rc")" >&2
done
