"""multibond's exceptions: a bad model (ModelError) and a failed run (SimulationError)."""


class Diagnostic:
    """One problem found in a model, as the command line prints it (``text``)."""

    __slots__ = ("file", "line", "column", "element", "code", "message", "hint", "details", "severity", "text")

    def __init__(self, file="", line=0, column=0, element="", code="", message="", hint="", details=(),
                 severity="error", text=""):
        self.file, self.line, self.column = file, line, column
        self.element, self.code, self.message, self.hint = element, code, message, hint
        self.details, self.severity, self.text = list(details), severity, text

    def __str__(self):
        return self.text

    def __repr__(self):
        return f"Diagnostic({self.text!r}, code={self.code!r})"


class ModelError(Exception):
    """A bad model: every problem found, located. ``file``, ``line``, ``column``, ``element``,
    ``code``, ``hint`` and ``message`` are those of the first error; ``diagnostics`` lists all."""

    def __init__(self, message, diagnostics=()):
        super().__init__(message)
        self.diagnostics = list(diagnostics)
        errors = [d for d in self.diagnostics if d.severity == "error"] or self.diagnostics
        first = errors[0] if errors else Diagnostic(message=message)
        self.file, self.line, self.column = first.file, first.line, first.column
        self.element, self.code, self.hint = first.element, first.code, first.hint
        self.message = first.message


class SimulationError(Exception):
    """A run that failed (a step the solver could not take, a state that overflowed): ``results``
    holds the rows computed until then (None when the run stopped before its output)."""

    def __init__(self, message, results=None):
        super().__init__(message)
        self.message = message
        self.results = results
