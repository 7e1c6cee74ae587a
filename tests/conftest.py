"""The test suite renders with the general kernel (every feature compiled in: one compile serves every
test, `renderer/host/features.py`); tests/renderer/test_specialize.py renders specialised kernels and
checks them against it bit for bit.  Subprocesses (the CLI tests) inherit the setting."""
import os

os.environ.setdefault('RTC_KERNELS', 'general')
