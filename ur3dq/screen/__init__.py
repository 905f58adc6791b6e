"""The cell's screen (`ur3dq serve`): a pendant in the browser over the library — the live arm in 3D, the program,
teach and jog, check and run, the robot panel.

    access.py      who may open it (loopback, or a token)
    station.py     the robot connection, the live state, the store watched for changes
    operations.py  what each button does (the driver, the store, the program planner, the path check, the jog)
    editing.py     the program's edits with undo/redo, through the store's locked, atomic updates
    views.py       what the page shows, numbers in the page's units (ur3dq.units)
    scene.py       the 3D view's shapes: the path check's link capsules, the cell, the poses' frames
    pages.py       the open pages and which one has control
    server.py      the web server (Starlette, uvicorn): the page, its WebSocket, /healthz
    static/        the page (HTML, CSS, JS) and three.js, all inside the package: nothing comes from the internet
"""
