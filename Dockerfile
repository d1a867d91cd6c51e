# linkview: the viewer server, with an embedded mock controller unless the cell names one.
#   docker build -t linkview . && docker run -p 8000:8000 -e LINKVIEW_VIEWER_TOKEN=<secret> linkview
# Then open http://<host>:8000/?token=<secret> (the link sets a cookie; share it only with viewers).
# Your own cell: -v $PWD/mycell:/cell -e LINKVIEW_CELL=/cell/cell.toml, passwords as -e variables.
FROM python:3.11-slim

WORKDIR /app
COPY pyproject.toml setup.py README.md ./
COPY server ./server
COPY static ./static
COPY assets ./assets
COPY cells ./cells
RUN pip install --no-cache-dir . \
 && useradd --create-home --uid 10001 --shell /usr/sbin/nologin linkview
# Never root: whoever breaks into the server gets a user that owns nothing but its cache.
USER linkview

# Inside a container the port must be reachable from outside it. Without a viewer token the
# server warns that anyone who reaches the port can watch: set LINKVIEW_VIEWER_TOKEN.
ENV LINKVIEW_HOST=0.0.0.0 \
    LINKVIEW_PORT=8000
EXPOSE 8000
# 503 while no data source delivers samples.
HEALTHCHECK --interval=10s --timeout=3s --start-period=20s --retries=3 CMD ["python", "-m", "server.healthcheck"]
CMD ["python", "-m", "server"]
