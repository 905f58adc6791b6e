"""The screen's browser tests run with the system Chromium; without it (or Playwright) they are skipped, saying why."""
import pytest

from screen_support import require_browser


@pytest.fixture(scope="module")
def browser():
    """A headless Chromium for one test module."""
    require_browser()
    from screen_support import chromium

    with chromium() as launched:
        yield launched
