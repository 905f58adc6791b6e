"""RTDE server (port 30004): wire format (protocol), variable table (variables), input rules (inputs), sockets (server)."""
