; expect: 3 empty file
