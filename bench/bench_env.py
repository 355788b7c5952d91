"""Shared by the bench scripts: re-run the calling script under bench/.venv, which
setup_venv.sh (re)creates from the pinned requirements.txt, so every script works on a fresh
clone with a plain `bench/<script>.py`."""
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def ensure_venv(requirements="requirements.txt"):
    """Re-runs the current script under bench/.venv (bench/.venv-NAME for
    requirements-NAME.txt) if it is not already running there."""
    python = subprocess.run([os.path.join(HERE, "setup_venv.sh"), requirements], check=True, capture_output=True, text=True).stdout.strip()
    if os.path.realpath(sys.prefix) != os.path.realpath(os.path.dirname(os.path.dirname(python))):
        os.execv(python, [python] + sys.argv)


def ensure_modules(*names):
    """Runs in the current interpreter when it already has `names` (e.g. a CI venv with the
    peers), else under bench/.venv (ensure_venv)."""
    import importlib

    try:
        for name in names:
            importlib.import_module(name)
    except ImportError:
        ensure_venv()
