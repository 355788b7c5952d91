"""The package's PEP 517 build backend: maturin's, plus the type stubs ``motionlab/_typed.pyi``
generated from the module just built.

Why a wrapper: the stubs (one typed function per registered plugin, its docstring what
``motionlab describe`` prints) are made from the plugin registry, which exists only in the
linked extension — each plugin crate adds its entry at link time through ``inventory`` — so
they can be written only after the extension is compiled, and maturin has no step that runs the
built module before it packs the wheel. This backend lets maturin build the wheel, loads the
wheel's extension in a throwaway package beside ``_kinds.py`` and ``_stubgen.py`` (neither
imports NumPy or Polars, so this works in pip's isolated build environment, which has only
maturin), runs ``python -m motionlab._stubgen`` there and adds its output to the wheel
(RECORD updated). So the stubs are never committed: a new plugin (``motionlab plugin new``)
is in them after the next ``pip install`` with no other command.

Editable installs (``pip install -e``) import the package from ``python/``: there the stubs are
written to ``python/motionlab/_typed.pyi`` (ignored by git).
"""

import base64
import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
import zipfile

import maturin
from maturin import (  # noqa: F401  (the hooks maturin answers unchanged)
    build_sdist,
    get_requires_for_build_editable,
    get_requires_for_build_sdist,
    get_requires_for_build_wheel,
    prepare_metadata_for_build_editable,
    prepare_metadata_for_build_wheel,
)

PACKAGE = "motionlab"
STUBS = f"{PACKAGE}/_typed.pyi"
HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE = os.path.join(os.path.dirname(HERE), "python", PACKAGE)


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    name = maturin.build_wheel(wheel_directory, config_settings, metadata_directory)
    wheel = os.path.join(wheel_directory, name)
    _add_to_wheel(wheel, STUBS, _stubs_from(wheel).encode())
    return name


def build_editable(wheel_directory, config_settings=None, metadata_directory=None):
    name = maturin.build_editable(wheel_directory, config_settings, metadata_directory)
    stubs = _stubs_from(os.path.join(wheel_directory, name))
    with open(os.path.join(SOURCE, "_typed.pyi"), "w", encoding="utf-8") as f:
        f.write(stubs)
    return name


def _stubs_from(wheel):
    """The stubs of the extension in `wheel` (or, for an editable wheel without it, the one
    maturin put in the source folder)."""
    with tempfile.TemporaryDirectory() as tmp:
        pkg = os.path.join(tmp, PACKAGE)
        os.makedirs(pkg)
        with zipfile.ZipFile(wheel) as z:
            native = [n for n in z.namelist() if n.startswith(f"{PACKAGE}/_motionlab") and n.endswith((".so", ".pyd"))]
            for n in native:
                with z.open(n) as src, open(os.path.join(pkg, os.path.basename(n)), "wb") as dst:
                    shutil.copyfileobj(src, dst)
        if not native:
            found = [f for f in os.listdir(SOURCE) if f.startswith("_motionlab") and f.endswith((".so", ".pyd"))]
            if not found:
                sys.exit(f"motionlab_build: no compiled motionlab._motionlab in {wheel} or {SOURCE}; cannot write the stubs")
            for f in found:
                shutil.copy(os.path.join(SOURCE, f), pkg)
        for f in ("_kinds.py", "_stubgen.py"):
            shutil.copy(os.path.join(SOURCE, f), pkg)
        open(os.path.join(pkg, "__init__.py"), "w").close()
        env = dict(os.environ, PYTHONPATH=tmp)
        out = subprocess.run([sys.executable, "-m", f"{PACKAGE}._stubgen"], cwd=tmp, env=env, capture_output=True, text=True)
        if out.returncode != 0 or not out.stdout:
            sys.exit(f"motionlab_build: writing the stubs from the built module failed:\n{out.stderr}")
        return out.stdout


def _record_line(path, data):
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    return f"{path},sha256={digest},{len(data)}"


def _add_to_wheel(wheel, path, data):
    """Rewrites `wheel` with `path` holding `data` (replacing an entry of that name) and its
    RECORD line."""
    tmp = wheel + ".tmp"
    with zipfile.ZipFile(wheel) as src, zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED) as dst:
        record = next(n for n in src.namelist() if n.endswith(".dist-info/RECORD"))
        for item in src.infolist():
            if item.filename in (path, record):
                continue
            dst.writestr(item, src.read(item.filename))
        dst.writestr(path, data)
        lines = [l for l in src.read(record).decode().splitlines() if l and not l.startswith(path + ",")]
        lines.insert(len(lines) - 1 if lines and lines[-1].startswith(record + ",") else len(lines), _record_line(path, data))
        dst.writestr(record, "\n".join(lines) + "\n")
    os.replace(tmp, wheel)
