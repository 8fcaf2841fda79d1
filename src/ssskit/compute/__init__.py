"""Compute machinery shared by the layers above (no physics here): :mod:`ssskit.compute.numba_math`, the
vectorisable float32 functions and LLVM intrinsics of the numba kernels (the screen-space passes and the
MCML engine), and :mod:`ssskit.compute.gl`, the process's OpenGL 4.3 compute context through EGL (the gl
backend's passes and the MCML GLSL engine), and :mod:`ssskit.compute.fft`, the FFT convolution of the exact 2D
convolutions. Importing this package imports neither numba nor moderngl."""
