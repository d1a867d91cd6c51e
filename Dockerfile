# linkview: the viewer server with its embedded mock controller.
#   docker build -t linkview . && docker run -p 8000:8000 linkview
# Point it at a controller with: -e LINKVIEW_CTRLX_URL=https://<device> (plus user/password).
FROM python:3.11-slim

WORKDIR /app
COPY pyproject.toml README.md ./
COPY server ./server
RUN pip install --no-cache-dir -e .
COPY static ./static
COPY assets ./assets

# Inside a container the port must be reachable from outside it.
ENV LINKVIEW_HOST=0.0.0.0 \
    LINKVIEW_PORT=8000
EXPOSE 8000
CMD ["python", "-m", "server"]
