# SPDX-License-Identifier: MIT
"""``python -m pkss COMMAND [options]``:

    python -m pkss align SOURCE TARGET [options]   the pkss-align tool
    python -m pkss info [options]                  the pkss-info tool
    python -m pkss batch ...                       batch registration (pkss._batch_cli)

``align`` and ``info`` run the C tools bundled in the wheel, with their own
options and exit codes (``python -m pkss align --help``): 0 success,
2 usage error, 3 I/O error, 4 bad input data, 5 registration failed,
130 interrupted.
"""
from __future__ import annotations

import importlib
import importlib.util
import sys
from typing import List, Optional

from . import _tools

USAGE = """usage: python -m pkss {align,info,batch} [options]

  align SOURCE TARGET [options]  register SOURCE onto TARGET (the pkss-align tool)
  info [options]                 library version, devices, build options (pkss-info)
  batch [options]                many pairs at once (pkss._batch_cli), when available

'python -m pkss align --help' lists the options of a command.
"""

_TOOLS = {"align": "pkss-align", "info": "pkss-info"}


def main(argv: Optional[List[str]] = None, replace: bool = True) -> int:
    """Dispatch a command; returns the exit code (align/info exec the tool
    when `replace`, so they return only on failure to start it)."""
    args = list(sys.argv[1:] if argv is None else argv)
    if not args or args[0] in ("-h", "--help"):
        (sys.stdout if args else sys.stderr).write(USAGE)
        return 0 if args else 2
    cmd, rest = args[0], args[1:]
    if cmd in _TOOLS:
        return _tools.run(_TOOLS[cmd], rest, replace=replace)
    if cmd == "batch":
        if importlib.util.find_spec("pkss._batch_cli") is None:
            sys.stderr.write("pkss: 'batch' is not available in this version of pkss "
                             "(no module pkss._batch_cli)\n")
            return 2
        return int(importlib.import_module("pkss._batch_cli").main(rest))
    sys.stderr.write("pkss: unknown command %r\n\n%s" % (cmd, USAGE))
    return 2


if __name__ == "__main__":
    sys.exit(main())
