"""Wrong uses of the API that a type checker must catch (tests/test_typing.py)."""

from __future__ import annotations

from typing import Literal

import fuzzynav

won: Literal["won"] = fuzzynav.simulate("s1").outcome
count: int = fuzzynav.sweep("p", n=2)[0]["controller"]
