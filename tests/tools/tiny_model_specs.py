#!/usr/bin/env python3
"""How tests/data/tiny_models/*.json were made (run once by a developer; the build never runs it): the tensors of
the reference fixtures' tiny random-weight models in ../shared/fixtures (names, shapes, shared storages, the .pth's
args), each with the rule it is drawn by — the fixtures' own descriptions of their random weights (their READMEs;
Metric3D's config.json lists one per parameter) — so that freeloc's generator (make_tiny_models.cc) writes models of
the same architectures with its own values.

    python3 tests/tools/tiny_model_specs.py build/tests/make_tiny_models ../shared/fixtures tests/data/tiny_models
"""
import json, math, re, subprocess, sys

TOOL, F, OUT = sys.argv[1], sys.argv[2].rstrip('/') + '/', sys.argv[3]


def dump(rel):
    return json.loads(subprocess.run([TOOL, '--dump', F + rel], check=True, capture_output=True, text=True).stdout)

def fan_in(shape):
    return max(1, math.prod(shape[1:])) if len(shape) >= 2 else 1
def dust_like(name, shape, last_scale):
    if name.endswith('.bias'):
        s = 'normal 0.1'
    elif len(shape) >= 2:
        s = 'normal %.9g' % (1 / math.sqrt(fan_in(shape)))
    elif 'norm' in name and name.endswith('.weight'):
        s = 'one_plus_normal 0.2'
    else:
        s = 'normal 1'  # tokens
    if re.search(r'downstream_head\d\.dpt\.head\.4\.(weight|bias)$', name):
        s += ' scale %g' % last_scale
    return s
ONE_D = set()
def seggpt(name, shape):
    base = name.split('.')[-1]
    if 'rel_pos_' in name: return 'normal 0.25'
    if base in ('pos_embed',) or name.endswith('_token') or 'token' in base: return 'normal 0.5'
    final = ' scale %.9g' % (1 / 0.7065) if name.startswith('decoder_pred.3.') else ''
    if name.endswith('.weight') and len(shape) == 1: return 'one_plus_normal 0.2'  # LayerNorm / LayerNorm2D
    if name.endswith('.bias') and len(shape) == 1 and (name[:-5] + '.weight') in ONE_D: return 'normal 0.1'
    if name.endswith('.bias'): return 'normal 0.05' + final
    if len(shape) >= 2: return 'normal %.9g' % (1 / math.sqrt(fan_in(shape))) + final
    return 'normal 0.5'
def metric3d(name, shape, per, gains):
    v = per.get(name)
    if v is None:  # norm layers the fixture's log does not list
        if name.endswith('running_var'): return 'one'
        if name.endswith('running_mean'): return 'zero'
        return 'one_plus_normal 0.2' if name.endswith('.weight') and len(shape) == 1 else 'normal 0.1'
    m = re.match(r'w N\(0,([0-9.]+)/sqrt\(([0-9.]+)\)\)', v)
    if m: s = 'normal %.9g' % (float(m.group(1)) / math.sqrt(float(m.group(2))))
    elif re.match(r'(b|ln|tok|pos) N\(0,([0-9.]+)\)', v): s = 'normal ' + re.match(r'\w+ N\(0,([0-9.]+)\)', v).group(1)
    elif re.match(r'(ln|ls) U\(([-0-9.]+),([-0-9.]+)\)', v):
        m = re.match(r'\w+ U\(([-0-9.]+),([-0-9.]+)\)', v); s = 'uniform %s %s' % (m.group(1), m.group(2))
    else: raise SystemExit('unknown init ' + v)
    for prefix, g in gains:
        if name.startswith('depth_model.' + prefix) or name.startswith(prefix):
            s += ' scale %g' % g
    return s
out = OUT
# DUSt3R / MASt3R: .pth with args
for fam, rel, last in [('dust3r', 'pth/dust3r_tiny.pth', 0.3), ('mast3r', 'mast3r/mast3r_tiny.pth', 0.15)]:
    d = dump(rel)
    spec = {'file': fam + '_tiny.pth', 'format': 'pth', 'state_dict_root': 'model',
            'args': {k[5:]: v for k, v in d['metadata'].items() if k.startswith('args.')}, 'tensors': []}
    for t in d['tensors']:
        name, shape = t[0], t[1]
        assert name.startswith('model.')
        init = ('alias ' + t[2][6:]) if len(t) > 2 else dust_like(name[6:], shape, last)
        spec['tensors'].append([name[6:], shape, init])
    # The same weights also as model.safetensors + config.json (the layout of the fixtures' weights.safetensors).
    cfg = json.load(open(F + fam + '/config.json'))
    spec['copy'] = {'file': fam + '/model.safetensors', 'config': {k: v for k, v in cfg.items() if k != 'cases'}}
    json.dump(spec, open(out + '/' + fam + '.json', 'w'), indent=None, separators=(',', ':'))
# SegGPT
d = dump('seggpt/weights.safetensors')
ONE_D = {t[0] for t in d['tensors'] if len(t[1]) == 1 and t[0].endswith('.weight')}
cfg = json.load(open(F + 'seggpt/config.json'))
spec = {'file': 'seggpt/model.safetensors', 'format': 'safetensors', 'config': cfg,
        'tensors': [[t[0], t[1], seggpt(t[0], t[1])] for t in d['tensors']]}
json.dump(spec, open(out + '/seggpt.json', 'w'), separators=(',', ':'))
# Metric3D
d = dump('metric3d/final_norm/weights.safetensors')
cfg = json.load(open(F + 'metric3d/final_norm/config.json'))
per = dict(cfg['weights']['init_per_parameter']); gains = cfg['weights']['gains']
small = {k: cfg[k] for k in ('encoder', 'decoder', 'data') if k in cfg}
spec = {'file': 'metric3d/model.safetensors', 'format': 'safetensors', 'config': small,
        'tensors': [[t[0], t[1], metric3d(t[0], t[1], per, gains)] for t in d['tensors']]}
json.dump(spec, open(out + '/metric3d.json', 'w'), separators=(',', ':'))
