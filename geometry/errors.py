"""Errors raised by :mod:`geometry` for designs and files that cannot be used."""


class GeometryError(ValueError):
    """Base class: a design, a parameter or a file the geometry cannot accept."""


class ParameterError(GeometryError):
    """A parameter value breaks its rule (the message names parameter, value and rule)."""


class InfeasibleDesignError(GeometryError):
    """A design fails a feasibility rule; ``rule`` names it."""

    def __init__(self, rule: str, message: str):
        super().__init__(f"infeasible design: rule '{rule}' fails: {message}")
        self.rule = rule
