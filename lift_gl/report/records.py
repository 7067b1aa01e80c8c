"""Writing a run's JSON record (benchmarks, reports): the folder made first, then the file."""
from __future__ import annotations

import json
from pathlib import Path


def write_json(path, data, indent: int = 1) -> None:
    """`data` as JSON at `path`, its folder made first (a results/ subfolder a run names)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=indent))
