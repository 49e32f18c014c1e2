"""The product's web pages: the recording view (and, served by the HTTP service, fleet and engine views).

Pages are HTML with the data they show embedded as JSON and drawn in the
browser by ``static/pages.js`` with uPlot (1.6.32, MIT, vendored under
``static/vendor/``: charts with zoom by dragging and values on hover). Nothing
is fetched from elsewhere: the service serves the scripts from the installed
package, and a page written for a ship without network (``compare --plot
FILE.html``) carries them inline.
"""

from monitor.report.web.pages import STATIC, engine_page, fleet_page, recording_page

__all__ = ["STATIC", "engine_page", "fleet_page", "recording_page"]
