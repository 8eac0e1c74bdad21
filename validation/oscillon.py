"""Oscillon presets: see :mod:`validation.presets`.  Run: python -m validation.oscillon"""
from validation.presets import main as _main
from validation.presets import study


def main():
    return _main("axisymmetric")


__all__ = ["main", "study"]

if __name__ == "__main__":
    main()
