"""The result bunch shared by all solvers (modelled on ``scipy.optimize.OptimizeResult``)."""


class Bunch(dict):
    """A dict whose keys are also attributes.

    Every solver in the package returns a subclass of this, carrying at least
    ``success``/``converged``, ``status`` and ``message`` where applicable.

    Examples
    --------
    >>> b = Bunch(converged=True, nit=3)
    >>> b.nit
    3
    """

    def __getattr__(self, name):
        try:
            return self[name]
        except KeyError as exc:
            raise AttributeError(name) from exc

    def __setattr__(self, name, value):
        self[name] = value

    def __delattr__(self, name):
        try:
            del self[name]
        except KeyError as exc:
            raise AttributeError(name) from exc

    def __repr__(self):
        if not self:
            return f"{type(self).__name__}()"
        width = max(map(len, map(str, self))) + 1
        lines = []
        for key, value in self.items():
            text = repr(value)
            if len(text) > 200:
                text = text[:197] + "..."
            lines.append(f"{str(key).rjust(width)}: {text}")
        return "\n".join(lines)

    def __dir__(self):
        return list(self.keys())
