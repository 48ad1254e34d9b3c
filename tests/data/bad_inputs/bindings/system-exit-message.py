# expect: 3 running it called sys.exit('bye')
raise SystemExit('bye')
