import subprocess, signal, time, random, shutil, pathlib
for i in range(4):
    root=pathlib.Path(f'/tmp/sigt/r{i}'); shutil.rmtree(root, ignore_errors=True); root.mkdir()
    p=subprocess.Popen(['/work/main/.venv/bin/python','/tmp/sigt/wrap.py','simulate','--out',str(root/'out'),'--duration','20000','--rate','1000'],stdout=subprocess.PIPE,stderr=subprocess.PIPE,text=True)
    while not any(x.name.startswith('.') for x in root.iterdir()):
        if p.poll() is not None: break
        time.sleep(0.005)
    p.send_signal(signal.SIGTERM); out,err=p.communicate(timeout=120)
    print('RC', p.returncode, err[-3000:])
    shutil.rmtree(root, ignore_errors=True)
