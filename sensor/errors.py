"""The errors of :mod:`sensor`, one tree with one root.

- :class:`SensorError` is the root: ``except SensorError`` catches everything the package
  raises on purpose.
- :class:`SensorInputError` (also a ``ValueError``): an input breaks its rule; the message
  names the field, the value and the rule.
- :class:`SolverError` (also a ``RuntimeError``): a computation that could not finish; the
  message names the stage (increment, load, residual).

The geometry and MRI packages have their own roots (:mod:`geometry.errors`,
:mod:`mri.errors`); the command line maps all three to one line and exit status 2.
"""


class SensorError(Exception):
    """Root of every error raised by :mod:`sensor`."""


class SensorInputError(SensorError, ValueError):
    """An input the sensor tools cannot accept (names field, value and rule)."""


class OpticsError(SensorInputError):
    """An optics input breaks its rule."""


class HysteresisError(SensorInputError):
    """A loop that cannot give a hysteresis value (too short, not a loop, bad columns)."""


class SensorRangeError(SensorInputError):
    """A force the sensor cannot read (NaN, negative, beyond range) or a setup it cannot hold."""


class SweepError(SensorInputError):
    """A sweep that cannot run: bad grid, unreachable scheduler, mismatched resume."""


class UsageError(SensorInputError):
    """A combination of command-line arguments that a command cannot run."""


class SolverError(SensorError, RuntimeError):
    """A solve that failed: the message names the increment, the load and the residual."""


class SingularSystemError(SolverError):
    """The assembled system of eqs 85-86 is singular (a mechanism, or a missing support)."""


class UnreachableTargetError(SolverError):
    """The output cannot reach the target travel (it moves the wrong way or stalls)."""


class ConvergenceError(SolverError):
    """The equilibrium residual would not fall below the tolerance."""


class InstabilityError(SolverError):
    """The equilibrium reached is unstable: the tangent stiffness has a negative mode (the
    body would buckle sideways or snap away from the path the solver follows)."""


class SnapThroughError(InstabilityError):
    """The input force fell while the output travel grew: a limit point (snap-through)."""


class CapacityWarning(UserWarning):
    """A reference asks for more force than the actuator (or sensor) can give."""


class ClusterLostError(SensorError, RuntimeError):
    """The Dask cluster went away (every worker, or the scheduler) during a sweep; the cells
    finished so far are checkpointed and ``resume`` completes the sweep."""


class SweepInterrupted(KeyboardInterrupt):
    """Ctrl-C or SIGTERM stopped a sweep after its finished cells were checkpointed. Not an
    error of the input: a KeyboardInterrupt that says how far the sweep got, for the one
    line the command prints; ``signum`` is the signal (SIGINT or SIGTERM)."""

    def __init__(self, message: str, signum: int):
        super().__init__(message)
        self.signum = signum


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread like Ctrl-C's KeyboardInterrupt, so that every
    command stops the same orderly way (checkpoint, one line, exit status 143)."""


class ResourceNote(UserWarning):
    """A request the tool changed to fit the machine (e.g. more workers than cores)."""


class DesignError(SensorInputError):
    """A range-targeted design that cannot be made: a bad target or bounds, or a range no
    feasible body reaches (the message names the reachable interval)."""


class ArtefactError(SensorInputError):
    """An MRI artefact prediction that cannot run: a bad protocol, B0 direction, grid or a
    material without a susceptibility (:mod:`sensor.artefact`)."""
