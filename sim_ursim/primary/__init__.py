"""Primary (30001), secondary (30002) and realtime (30003) client interfaces.

`packets` and `realtime` turn controller snapshots into bytes (pure); `server` owns the sockets.
"""
