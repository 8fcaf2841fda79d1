"""The live viewer: a WebGL2 page whose shaders are the ones ``ssskit export`` writes, a local server
bound to 127.0.0.1, and the headless-browser driver (:mod:`ssskit.view.browser`) that the viewer's tests,
``benchmarks/bench_view.py`` and the Babylon.js client tests share."""
