# contactnet in a container: the web tool on port 8000 (3D view on 8080).
#   docker build -t contactnet . && docker run -p 8000:8000 -p 8080:8080 contactnet
# torch is pinned to 2.13.0; to get its CPU-only build, pass your CPU wheel index with
#   --build-arg PIP_EXTRA_INDEX_URL=<index>
FROM python:3.11-slim
ARG PIP_EXTRA_INDEX_URL=""
ENV PIP_EXTRA_INDEX_URL=${PIP_EXTRA_INDEX_URL} PIP_NO_CACHE_DIR=1 PYTHONUNBUFFERED=1
WORKDIR /opt/contactnet
COPY . .
RUN pip install -e .
EXPOSE 8000 8080
CMD ["contactnet", "serve", "--host", "0.0.0.0"]
