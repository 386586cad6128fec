"""The live web console served at ``/``: static page assets and the ``/v1/events`` stream.

:mod:`robodcn.web.assets` serves the HTML, CSS and JavaScript shipped as package data (no
build step, nothing fetched from elsewhere); :mod:`robodcn.web.events` publishes the arm's
state, move status changes and alerts as Server-Sent Events from one shared sampler.
"""

from robodcn.web.assets import answer, asset
from robodcn.web.events import EventHub, serve

__all__ = ["EventHub", "answer", "asset", "serve"]
