"""Issue 32: at 1024 px (a laptop, a half screen) the top bar keeps every control and the whole
status line visible: nothing of it is cut off or hidden behind the bar's edge."""
from __future__ import annotations

import pytest
from _studio import open_page

BAR_FITS = """() => {
  const bar = document.getElementById("bar"), status = document.getElementById("status");
  const r = status.getBoundingClientRect(), b = bar.getBoundingClientRect();
  const cut = [...bar.children].filter((el) => {
    const q = el.getBoundingClientRect();
    return q.right > b.right + 0.5 || q.bottom > b.bottom + 0.5 || q.left < b.left - 0.5;
  }).map((el) => el.id || el.className || el.tagName);
  return {text: status.textContent, clipped: status.scrollWidth > status.clientWidth + 1,
          inside: r.right <= window.innerWidth + 0.5 && r.bottom <= b.bottom + 0.5 && r.width > 0,
          cut, overflow: bar.scrollWidth > bar.clientWidth + 1};
}"""


@pytest.mark.parametrize("width", [1024, 800])
def test_status_line_is_whole_in_a_narrow_window(studio, browser, width):
    page = open_page(browser, studio.url)
    try:
        page.set_viewport_size({"width": width, "height": 768})
        page.wait_for_function("document.getElementById('status').textContent.includes('shown in')",
                               timeout=90_000)
        # the longest status the page shows in normal use, plus a long file name beside it
        page.evaluate("document.getElementById('status').textContent = "
                      "'12345 triangles · 678 shapes · derive 1234 ms · export 567 ms · shown in 89 ms'")
        facts = page.evaluate(BAR_FITS)
        assert not facts["clipped"] and facts["inside"], facts
        assert facts["cut"] == [] and not facts["overflow"], facts
        view = page.evaluate("document.getElementById('view').getBoundingClientRect().height")
        assert view > 300  # the bar did not grow over the 3D view
    finally:
        page.context.close()
