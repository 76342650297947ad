"""``python -m uvpin.ray_sweep FILE [--address ADDR]``: ``uvpin sweep`` as Ray
tasks (see ``uvpin.ray``). Prints the summary; exit 1 on a bad sweep file."""

from __future__ import annotations

import argparse
import sys

from . import InputError


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m uvpin.ray_sweep", description=__doc__)
    parser.add_argument("sweep", help="the sweep file (RON)")
    parser.add_argument("--address", help="Ray cluster address (default: the local one, started if none)")
    parser.add_argument("--force", action="store_true", help="re-run every run, even those already done")
    parser.add_argument("--retries", type=int, default=3, help="retries of a task whose worker dies (default 3)")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
    args = parser.parse_args(argv)
    from . import ray as uvpin_ray

    try:
        summary = uvpin_ray.sweep(
            args.sweep,
            address=args.address,
            force=args.force,
            max_retries=args.retries,
            progress=not args.quiet,
        )
    except InputError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    print(summary, end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
