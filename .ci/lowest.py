"""Print pip constraints that pin every dependency of pyproject.toml (the project's and its
``dev`` extra's) to the lowest version it allows: ``name>=X`` becomes ``name==X``."""

import re
import sys
import tomllib
from pathlib import Path

project = tomllib.loads(Path(__file__).resolve().parents[1].joinpath("pyproject.toml").read_text())
requirements = (
    project["project"]["dependencies"] + project["project"]["optional-dependencies"]["dev"]
)
for req in requirements:
    m = re.fullmatch(r"\s*([A-Za-z0-9_.-]+)(?:\[[^]]*\])?\s*>=\s*([^,;\s]+).*", req)
    if m is None:
        sys.exit(f"no lower bound in {req!r}: every dependency names the oldest version it takes")
    print(f"{m.group(1)}=={m.group(2)}")
