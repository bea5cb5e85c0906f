"""What a power-down notice from the C&C runs.

References (docs/level2.md, its § table): §8.8 (power 0x0030: a broadcast the payload only
listens to; its layout is unknown, so ``PayloadConfig.is_power_down`` decides which notices mean
power down); the original glider payload software passed power-down messages on to the Pi;
docs/wave-glider.md#power-down-notices (a shutdown notice runs a configured command), issue 11 §5.

:func:`handle_power_down`: 1. log the notice with the frame in hex; 2. flush what must be kept
(the pending fixes, command results), each step on its own so one failing does not stop the
others; 3. run the configured command (default: none, log only) with a timeout. It never
raises: a power notice must not take the Level 2 link down with it.
"""

from __future__ import annotations

import logging
import shlex
import subprocess
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

log = logging.getLogger(__name__)

COMMAND_TIMEOUT_S = 30.0


@dataclass(frozen=True)
class PowerDownOutcome:
    flushed: list[str] = field(default_factory=list)  # names of the flush steps that worked
    flush_errors: list[str] = field(default_factory=list)
    returncode: int | None = None  # None: not run (no command, or it could not run)
    error: str = ""


def parse_command(text: str) -> list[str] | None:
    """A configured command line (``"sudo systemctl poweroff"``) as argv; empty means none."""
    argv = shlex.split(text)
    return argv or None


def handle_power_down(
    frame: bytes,
    *,
    command: Sequence[str] | None = None,
    flush: Sequence[tuple[str, Callable[[], object]]] = (),
    timeout_s: float = COMMAND_TIMEOUT_S,
) -> PowerDownOutcome:
    """Log, flush, then run ``command`` (argv, no shell); see the module docstring."""
    log.warning("power-down notice from the C&C: %s", frame.hex(" "))
    flushed: list[str] = []
    errors: list[str] = []
    for name, step in flush:
        try:
            step()
        except Exception as exc:  # noqa: BLE001 - the next step and the command still run
            log.exception("power down: flushing %s failed", name)
            errors.append(f"{name}: {exc}")
        else:
            flushed.append(name)
    if not command:
        log.warning("power down: no command configured (log only)")
        return PowerDownOutcome(flushed, errors)
    try:
        done = subprocess.run(
            list(command), timeout=timeout_s, check=False, capture_output=True, text=True
        )
    except subprocess.TimeoutExpired:
        log.error("power down: %s still running after %g s: killed", shlex.join(command), timeout_s)
        return PowerDownOutcome(flushed, errors, error=f"timed out after {timeout_s:g} s")
    except (OSError, ValueError) as exc:
        log.error("power down: cannot run %s: %s", shlex.join(command), exc)
        return PowerDownOutcome(flushed, errors, error=str(exc))
    level = logging.WARNING if done.returncode == 0 else logging.ERROR
    log.log(
        level,
        "power down: %s exited %d %s",
        shlex.join(command),
        done.returncode,
        (done.stderr or done.stdout).strip()[:500],
    )
    return PowerDownOutcome(flushed, errors, returncode=done.returncode)
