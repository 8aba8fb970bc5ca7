"""Open3D, imported on demand: the ``[scan]`` extra, never imported by the core.

Open3D's shared library links ``libusb-1.0.so.0`` (for its Azure Kinect reader), which a bare Linux
machine lacks, and ``import open3d`` then fails inside the dynamic loader. The ``libusb-package``
wheel ships that library; loading it into the process first (``ctypes.CDLL``, global symbols) lets
the loader resolve Open3D's dependency without any system package.
"""

from __future__ import annotations

import ctypes
import functools

from snakesim.framework.errors import SnakesimError

INSTALL_HINT = "pip install 'snakesim[scan]'"


class ScanExtraMissing(SnakesimError):
    """A package of the ``[scan]`` extra is not installed."""


@functools.cache
def import_open3d():
    """The ``open3d`` module, with libusb loaded first; a :class:`ScanExtraMissing` naming the install
    command when Open3D (or libusb-package) is not installed."""
    try:
        import libusb_package
    except ImportError:
        libusb_package = None
    if libusb_package is not None:
        lib = libusb_package.get_library_path()
        if lib is not None:
            # RTLD_GLOBAL: Open3D's library finds the symbols when the loader resolves its DT_NEEDED entry
            ctypes.CDLL(str(lib), mode=ctypes.RTLD_GLOBAL)
    try:
        import open3d
    except ImportError as e:
        raise ScanExtraMissing(f"importing scans needs Open3D ({e}): {INSTALL_HINT}") from None
    except OSError as e:   # a shared library that still cannot be loaded
        raise ScanExtraMissing(f"Open3D is installed but its library cannot be loaded ({e}); "
                               f"reinstall the extra: {INSTALL_HINT}") from None
    return open3d
