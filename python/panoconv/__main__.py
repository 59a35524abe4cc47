"""`python -m panoconv ARGS`: runs the `panoconv` command installed with this package."""

import os
import subprocess
import sys
import sysconfig


def main() -> int:
    exe = "panoconv.exe" if os.name == "nt" else "panoconv"
    command = os.path.join(sysconfig.get_path("scripts"), exe)
    if not os.path.isfile(command):
        sys.stderr.write(f"panoconv: the command is not installed at {command}\n")
        return 2
    return subprocess.call([command, *sys.argv[1:]])


if __name__ == "__main__":
    sys.exit(main())
