"""The contactnet web tool: FastAPI (REST + front page) and viser (3D view) around one live session."""
