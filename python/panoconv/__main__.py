"""`python -m panoconv ARGS`: runs the `panoconv` command installed with this package;
`python -m panoconv pandaset --input SEQ ...` converts a PandaSet sequence through its
Python adapter (panoconv.sources.pandaset) with the options of `panoconv nuscenes`."""

import os
import subprocess
import sys
from typing import Optional

PANDASET_HELP = """Convert a PandaSet sequence (a folder in PandaSet's layout: camera/, lidar/,
annotations/cuboids/, meta/): its six cameras stitched into a panorama (or the cameras of
--cameras converted), with its cuboids as KITTI labels and LiDAR depth. Needs pandas
(pip install panoconv[pandaset]).

Usage: python -m panoconv pandaset --input SEQ --to PROJECTION --output OUT [OPTIONS]

PandaSet's options:
  -i, --input <SEQ>      The sequence folder (e.g. /data/pandaset/002)
      --lidar <WHICH>    both (default), pandar64 (360°) or pandargt (forward), or none
                         (no scan: no --depth, and the stitch is fixed)
      --vehicle-box <BOX>
                         The car's own returns, dropped: X0,Y0,Z0,X1,Y1,Z1 (least and
                         greatest corner in the LiDAR's pose frame, metres) or none
                         [default: -1,-1.3,1,1,2.2,2, the roof and the sensor's mount]

Examples:
  python -m panoconv pandaset --input /data/pandaset/002 --to equirect --output /tmp/pandaset_equi --pano-width 2048 --depth
  python -m panoconv pandaset --input /data/pandaset/002 --to cylindrical --cameras front_left_camera,front_camera,front_right_camera --output O

The other options are those of every rig command (panoconv nuscenes):
"""


def _take(args: list, names: tuple) -> tuple:
    """The value of the first of `names` in `args` (`--x V` or `--x=V`), and the rest."""
    value, rest, i = None, [], 0
    while i < len(args):
        a = args[i]
        flag, eq, given = a.partition("=")
        if flag in names:
            if eq:
                value = given
            elif i + 1 < len(args):
                value, i = args[i + 1], i + 1
            else:
                value = ""
        else:
            rest.append(a)
        i += 1
    return value, rest


def _vehicle_box(given):
    """`--vehicle-box`: True for the default, None for `none`, the two corners, or False."""
    if given is None:
        return True
    if given == "none":
        return None
    try:
        v = [float(x) for x in given.split(",")]
    except ValueError:
        return False
    if len(v) != 6 or not all(a < b for a, b in zip(v[:3], v[3:])):
        return False
    return (tuple(v[:3]), tuple(v[3:]))


def _without_scan(rest: list) -> Optional[str]:
    """With `--lidar none` there is no scan: the error for an option that needs one, else None;
    a stitch left to its default (depth-guided) is asked for fixed (`rest` grows), with a note,
    so that the manifest records the stitch the frames get."""
    if "--depth" in rest:
        return (
            "--depth writes the LiDAR's depth, and --lidar none reads no scan: "
            "drop --depth or choose --lidar both, pandar64 or pandargt"
        )
    mode, _ = _take(rest, ("--stitch-mode",))
    if mode == "depth":
        return (
            "--stitch-mode depth is guided by the LiDAR's scan, and --lidar none reads none: "
            "use --stitch-mode fixed or choose --lidar both, pandar64 or pandargt"
        )
    if mode is None:
        rest += ["--stitch-mode", "fixed"]
        if "--quiet" not in rest and "-q" not in rest:
            sys.stderr.write(
                "panoconv: --lidar none: no scan to guide the stitch, so it is fixed "
                "(--stitch-mode fixed: every pixel at --stitch-distance)\n"
            )
    return None


def _source_options(lidar: Optional[str], box) -> str:
    """The adapter's options as `rig-stream --source-options` records them in the manifest."""
    corners = "none" if box is None else ",".join(repr(float(v)) for c in box for v in c)
    return f"pandaset lidar={lidar or 'none'} vehicle_box={corners}"


def pandaset(args: list) -> int:
    from .rig import command, convert_rig

    if any(a in ("-h", "--help") for a in args):
        sys.stdout.write(PANDASET_HELP)
        sys.stdout.flush()
        return subprocess.call([command(), "rig-stream", "--help"])
    given, rest = _take(args, ("--input", "-i"))
    lidar, rest = _take(rest, ("--lidar",))
    vehicle, rest = _take(rest, ("--vehicle-box",))
    output, rest = _take(rest, ("--output", "-o"))
    missing = [n for n, v in (("--input", given), ("--output", output)) if not v]
    if missing:
        sys.stderr.write(f"panoconv: error: pandaset needs {' and '.join(missing)} (see --help)\n")
        return 2
    if lidar not in (None, "both", "pandar64", "pandargt", "none"):
        sys.stderr.write(f"panoconv: error: --lidar {lidar!r}: both, pandar64, pandargt or none\n")
        return 2
    if not os.path.isdir(os.path.join(given, "camera")):
        sys.stderr.write(f"panoconv: error: --input {given}: not a PandaSet sequence (no camera/)\n")
        return 2
    box = _vehicle_box(vehicle)
    if box is False:
        sys.stderr.write(
            f"panoconv: error: --vehicle-box {vehicle!r}: X0,Y0,Z0,X1,Y1,Z1 (metres) or none\n"
        )
        return 2
    if lidar == "none":
        problem = _without_scan(rest)
        if problem:
            sys.stderr.write(f"panoconv: error: {problem}\n")
            return 2
    try:
        from .sources.pandaset import VEHICLE_BOX, PandaSet

        which = None if lidar == "none" else (lidar or "both")
        vehicle_box = VEHICLE_BOX if box is True else box
        source = PandaSet(given, lidar=which, vehicle_box=vehicle_box)
    except ImportError as e:
        sys.stderr.write(f"panoconv: error: {e}: pip install panoconv[pandaset]\n")
        return 2
    except (OSError, ValueError, KeyError, IndexError) as e:
        sys.stderr.write(f"panoconv: error: {given}: {e}\n")
        return 2
    rest += ["--source-options", _source_options(which, vehicle_box)]
    return convert_rig(source, output, rest)


def main() -> int:
    if sys.argv[1:2] == ["pandaset"]:
        return pandaset(sys.argv[2:])
    from .rig import command

    exe = command()
    if not os.path.isfile(exe):
        sys.stderr.write(f"panoconv: the command is not installed at {exe}\n")
        return 2
    code = subprocess.call([exe, *sys.argv[1:]])
    if sys.argv[1:] in (["-h"], ["--help"]):
        print("\nFrom Python also: python -m panoconv pandaset --help (a PandaSet sequence through its adapter)")
    return code


if __name__ == "__main__":
    sys.exit(main())
