#!/usr/bin/env bash
# The learned demosaicing peer of the full `camsim bench` (not of --quick, not of CI):
# demosaicnet 0.0.14 from PyPI (Gharbi et al. 2016, pretrained weights in the wheel) on CPU
# torch, in .venv-learned, which camsim bench finds by itself ($CAMSIM_LEARNED_PYTHON
# overrides). If the system Python already has torch (Debian/Ubuntu: apt-get install
# python3-torch, CPU only, about 1 GB with its dependencies), the environment reuses it;
# otherwise pip installs torch from PyPI, whose Linux wheels bring CUDA libraries (several GB).
set -euo pipefail
cd "$(dirname "$0")/.."
if python3 -c "import torch" 2>/dev/null; then
  python3 -m venv --clear --system-site-packages .venv-learned
  torch_from="the system's torch $(python3 -c 'import torch; print(torch.__version__)')"
  .venv-learned/bin/python -m pip install --disable-pip-version-check --quiet \
    demosaicnet==0.0.14 --no-deps
else
  python3 -m venv --clear .venv-learned
  torch_from="torch from PyPI"
  .venv-learned/bin/python -m pip install --disable-pip-version-check --quiet \
    demosaicnet==0.0.14 torch
fi
# demosaicnet imports these at load time (its dataset and training helpers; pkg_resources left
# setuptools in 81). numpy is torch's own (a system torch is built against the system's).
.venv-learned/bin/python -m pip install --disable-pip-version-check --quiet \
  pillow imageio tqdm wget "setuptools<81"
.venv-learned/bin/python -c "import demosaicnet; demosaicnet.BayerDemosaick(pretrained=True)"
echo "created .venv-learned: demosaicnet 0.0.14 on ${torch_from}"
