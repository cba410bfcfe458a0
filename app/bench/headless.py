"""How the project drives a headless browser (the browser tests and `app/bench/live.py`): Debian's
chromium with software WebGL (SwiftShader), no GPU, no sandbox (CI containers run as root)."""

CHROMIUM = "/usr/bin/chromium"
LAUNCH_ARGS = (
    "--no-sandbox",
    "--enable-unsafe-swiftshader",
    "--use-angle=swiftshader",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-dev-shm-usage",
    "--mute-audio",
    "--no-first-run",
)
