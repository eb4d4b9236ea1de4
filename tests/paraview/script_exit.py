"""How the pvbatch/pvpython scripts here end: run ``main(*args)``, print a traceback on any
failure, and leave at once with 0 or 1 (ParaView may exit 0 after a failed script, and
a script's views can make a normal exit fail)."""
import os
import sys


def run(main, *args):
    try:
        main(*args)
        code = 0
    except BaseException:
        import traceback

        traceback.print_exc()
        code = 1
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)
