"""Wrong uses of the API that a type checker must catch (tests/test_typing.py): each line
marked ``# mypy: wrong`` is an error under ``mypy --strict``, and no other line is."""

from __future__ import annotations

from typing import Literal

import fuzzynav

won: Literal["won"] = fuzzynav.simulate("s1").outcome  # mypy: wrong
count: int = fuzzynav.sweep("p", n=2)[0]["controller"]  # mypy: wrong
fuzzynav.simulate("s1", controller=42)  # mypy: wrong
fuzzynav.sweep(controller=3.5, n=2)  # mypy: wrong
controller = fuzzynav.make_controller("p")
controller.no_such_method()  # mypy: wrong
