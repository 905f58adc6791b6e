"""Dashboard server (port 29999): protocol (lines in, replies out) apart from the socket server."""
