# A client for the robots of deploy/compose.yaml: pylibfranka and the repository's examples.
ARG BASE_IMAGE=python:3.11-slim
FROM ${BASE_IMAGE}
RUN python3 -m venv /opt/client \
    && /opt/client/bin/pip install --no-cache-dir --disable-pip-version-check \
        pylibfranka==0.21.3 numpy
ENV PATH=/opt/client/bin:$PATH
WORKDIR /client
COPY examples/ examples/
USER 10001:10001
