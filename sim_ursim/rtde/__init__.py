"""RTDE server (port 30004).

Wire format (protocol), variable table (variables), input rules (inputs), sockets (server).
"""
