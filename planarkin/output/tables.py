"""Result tables: streaming CSV writers (the columns themselves: planarkin.solver.layout).

Values are written in full double precision (shortest text that reads back to the same double),
so identical input gives byte-identical files.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


class CsvWriter:
    """A CSV file written chunk by chunk. The formatter (fastcsv: its tables are built at
    import, a start-up of their own) is imported here, not with this module, which the plot
    processes import for the names and units alone; DirectoryWriter imports it before it forks
    the writers."""

    def __init__(self, path: Path, header: list[str]):
        from .fastcsv import write_table
        self.write_table = write_table
        self.path = Path(path)
        self.f = open(self.path, "wb")
        self.f.write((",".join(header) + "\n").encode())

    def write(self, X: np.ndarray) -> None:
        if len(X):
            self.write_table(self.f, X)

    def close(self) -> None:
        self.f.close()
