"""Run the ParaView plugin checks (``pv_*.py`` here) with pytest inside pvbatch.

    xvfb-run -a -s '-screen 0 1280x1024x24' pvbatch tests/paraview/run.py [pytest args]

with ``pv-hdrvol paraview``'s environment (the shim on PYTHONPATH). ParaView's Python
is Debian's /usr/bin/python3 here; only the source tree is added to its path.
``tests/integrations/test_paraview.py`` runs this from the main suite.
"""
import os
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))

if __name__ == "__main__":
    sys.path.insert(0, ROOT)
    os.environ["PV_HDRVOL_IN_PARAVIEW"] = "1"  # tests/conftest.py collects tests/paraview only then
    files = sorted(os.path.join(HERE, f) for f in os.listdir(HERE) if f.startswith("pv_") and f.endswith(".py"))
    args = sys.argv[1:]
    # pvbatch takes single-dash options for itself (-rs becomes --rs): -q -rs are set here
    status = pytest.main(["-p", "no:cacheprovider", "--rootdir", ROOT, "-c", os.devnull, "-q", "-rs", *args,
                          *([] if any(a.endswith(".py") or "::" in a for a in args) else files)])
    sys.stdout.flush()
    sys.stderr.flush()
    # pvbatch may exit 0 after a failed script: leave with pytest's status, now
    os._exit(int(status))
