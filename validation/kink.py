"""Kink presets: see :mod:`validation.presets`.  Run: python -m validation.kink"""
from validation.presets import main as _main
from validation.presets import study


def main():
    return _main("planar")


__all__ = ["main", "study"]

if __name__ == "__main__":
    main()
