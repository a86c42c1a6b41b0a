"""ctest `python.pytest`: runs test_nvstim.py with pytest, or says SKIPPED: where numpy or pytest
is missing (Debian's python3-numpy, python3-pytest).

Usage: run_pytest.py TEST_DIR [PYTEST_ARGS...]
"""
import importlib.util
import sys

for name, package in (("numpy", "python3-numpy"), ("pytest", "python3-pytest")):
    if importlib.util.find_spec(name) is None:
        print(f"SKIPPED: {name} is not installed for {sys.executable} (Debian's {package})")
        sys.exit(0)

import pytest  # noqa: E402

here = sys.argv[1]
# No cache folder in the source tree; -rs lists every skip with its reason.
sys.exit(pytest.main([here, "-q", "-rs", "-p", "no:cacheprovider", "--rootdir", here,
                      *sys.argv[2:]]))
