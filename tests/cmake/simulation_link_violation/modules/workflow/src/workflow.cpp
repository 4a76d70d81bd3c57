int workflowSomething() { return 2; }
