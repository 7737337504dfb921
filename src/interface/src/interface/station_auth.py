"""Who may use the web operator station, ROS-free.

- Listening on a loopback address (the default, 127.0.0.1): only this machine can connect, no token. The
  Host header must name a loopback host, so a web page elsewhere cannot reach the station through a DNS
  name that resolves to 127.0.0.1 (DNS rebinding).
- Listening on any other address: every request needs the access token printed at start, as the query
  ``?token=``, the header ``X-Station-Token`` or ``Authorization: Bearer``; a page opened with the token gets
  a cookie so its scripts, styles and WebSocket need not repeat it. Without it: 401.
- The WebSocket (commands and live data) only accepts an Origin of the station itself, so another site
  open in the same browser cannot drive the drone.
"""
import hmac
import ipaddress
import secrets
from urllib.parse import urlsplit

COOKIE = "station_token"
HEADER = "X-Station-Token"
LOOPBACK_NAMES = ("localhost", "ip6-localhost")


def new_token():
    return secrets.token_urlsafe(24)


def is_loopback(host):
    """True for 127.0.0.0/8, ::1 and localhost (a bind address or a Host header's name)."""
    host = (host or "").strip().strip("[]").lower()
    if host in LOOPBACK_NAMES:
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def host_name(host_header):
    """The name part of a Host header: 'localhost:8080' -> 'localhost', '[::1]:80' -> '::1'."""
    host_header = (host_header or "").strip()
    if host_header.startswith("["):
        return host_header[1:host_header.find("]")] if "]" in host_header else host_header[1:]
    return host_header.rsplit(":", 1)[0] if host_header.count(":") == 1 else host_header


class Access:
    """The station's access rule for one bind address."""

    def __init__(self, bind_host, token=None):
        self.loopback_only = is_loopback(bind_host)
        self.token = None if self.loopback_only else (token or new_token())

    def check(self, host_header, query_token=None, header_token=None, authorization=None, cookie_token=None):
        """None when the request may go on, else (HTTP status, reason)."""
        if self.loopback_only:
            if not is_loopback(host_name(host_header)):
                return 403, ("the station listens on loopback only; open it as http://127.0.0.1:PORT/ "
                             "(Host %r refused)" % (host_header,))
            return None
        bearer = authorization[7:].strip() if authorization and authorization.lower().startswith("bearer ") else None
        for given in (query_token, header_token, bearer, cookie_token):
            if given and hmac.compare_digest(given.encode(), self.token.encode()):
                return None
        return 401, ("the station listens on a non-loopback address: add ?token=TOKEN (printed when the station "
                     "started) to the URL, or send it in the %s header" % HEADER)

    @staticmethod
    def origin_allowed(origin, host_header):
        """A WebSocket's Origin must be the station's own page (same host and port as the request)."""
        if not origin:
            return False
        parts = urlsplit(origin)
        return parts.scheme in ("http", "https") and parts.netloc.lower() == (host_header or "").strip().lower()
