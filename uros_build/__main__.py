from uros_build.cli import main

main()
