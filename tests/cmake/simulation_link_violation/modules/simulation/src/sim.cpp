int simulatedSomething() { return 1; }
