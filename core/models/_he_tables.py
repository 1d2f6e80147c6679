"""Write He's series tables again: ``python -m core.models._he_tables`` (``--check`` compares instead).

The tables of :mod:`core.models._he_series` are computed once from its code and shipped as
``core/models/_he_series.npz``; after an edit of the series or of the tables' grid, run this and commit the file
(``tests/core/models/test_he.py`` fails while the file and the code disagree). A separate module from
``_he_series``, which the package imports (``python -m`` on it would run a second copy of it).
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from core.models import _he_series


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m core.models._he_tables", description=__doc__.split("\n")[0]
    )
    parser.add_argument(
        "--check", action="store_true", help="compare the file with tables built now; exit 1 if they differ"
    )
    args = parser.parse_args(argv)
    if args.check:
        try:  # the file itself: load_tables would build the tables in memory for a damaged file
            stored = _he_series._read_tables(_he_series.TABLES_FILE)
        except _he_series.TablesFileError as exc:
            print(f"{_he_series.TABLES_FILE}: {exc}")
            return 1
        built = _he_series.build_tables()
        same = all(np.array_equal(stored[name], built[name]) for name in built)
        print(f"{_he_series.TABLES_FILE}: {'equal to' if same else 'DIFFERENT from'} the tables built now")
        return 0 if same else 1
    print(f"wrote {_he_series.write_tables()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
